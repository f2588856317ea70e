// SPDX-License-Identifier: Apache-2.0
#include "Mesh.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <cctype>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

namespace rockvdb {

Mesh meshLevelSet(const openvdb::FloatGrid& grid, double isovalue, double adaptivity)
{
    require(std::isfinite(adaptivity) && adaptivity >= 0 && adaptivity <= 1, "mesh",
            "adaptivity", "in [0, 1]", adaptivity);
    require(std::isfinite(isovalue), "mesh", "isovalue", "finite", isovalue);
    Mesh m;
    openvdb::tools::volumeToMesh(grid, m.points, m.triangles, m.quads, isovalue, adaptivity);
    // volumeToMesh emits clockwise polygons seen from outside a level set; reverse them so
    // OBJ/PLY consumers (right-handed, counter-clockwise front faces) see outward normals.
    for (auto& t : m.triangles) std::swap(t[0], t[2]);
    for (auto& q : m.quads) std::swap(q[0], q[2]);
    return m;
}

const Schema<MeshParams>& meshSchema()
{
    static const Schema<MeshParams> s = [] {
        Schema<MeshParams> t("mesh", "Mesh a level set (tools::volumeToMesh) and write OBJ or "
                                     "PLY with outward, counter-clockwise faces.");
        t.member(param("isovalue", ParamType::Real, "m", 0.0, Range::closed(-1e6, 1e6),
                       "Iso-surface value"), &MeshParams::isovalue);
        t.member(param("adaptivity", ParamType::Real, "", 0.0, Range::closed(0, 1),
                       "0 = uniform .. 1 = most adaptive"), &MeshParams::adaptivity);
        ParamInfo up = param("up", ParamType::Text, "", "z", Range::any(),
                             "Up axis of the written mesh: z (rockvdb) or y (what Blender's OBJ "
                             "import expects by default, Houdini)");
        up.choices = {"z", "y"};
        t.member(up, &MeshParams::up);
        return t;
    }();
    return s;
}

MeshParams::MeshParams() { meshSchema().reset(*this); }

Mesh meshGrid(const openvdb::FloatGrid& grid, const MeshParams& p)
{
    meshSchema().validate(p);
    requireLevelSet(grid, "mesh input");
    Mesh mesh = meshLevelSet(grid, p.isovalue, p.adaptivity);
    if (mesh.points.empty()) {
        fail<ValueError>("the result is empty: no surface at isovalue ", p.isovalue, " (the level "
                         "set's band holds values within +-", double(grid.background()),
                         "; an isovalue must lie inside it)");
    }
    return mesh;
}

void attachIds(Mesh& mesh, const openvdb::FloatGrid& surface, const openvdb::FloatGrid& ids,
               const std::string& name)
{
    const openvdb::math::Transform& xf = surface.transform();
    if (ids.transform() != xf) {
        fail<ValueError>("mesh: id grid '", ids.getName(), "' is not on the voxels of '",
                         surface.getName(), "' (its transform differs)");
    }
    std::vector<int> out(mesh.points.size(), -1);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, mesh.points.size()), [&](const auto& r) {
        auto sa = surface.getConstAccessor();
        auto ia = ids.getConstAccessor();
        for (size_t i = r.begin(); i != r.end(); ++i) {
            const openvdb::Vec3d q = xf.worldToIndex(openvdb::Vec3d(mesh.points[i]));
            const openvdb::Coord base(int(std::floor(q[0])), int(std::floor(q[1])), int(std::floor(q[2])));
            float best = std::numeric_limits<float>::infinity();
            for (int k = 0; k < 8; ++k) {
                const openvdb::Coord c = base.offsetBy(k & 1, (k >> 1) & 1, (k >> 2) & 1);
                const float id = ia.getValue(c);
                if (!(id >= 0)) continue;
                const float d = std::abs(sa.getValue(c));
                if (d < best) { best = d; out[i] = int(std::lround(id)); }
            }
        }
    });
    mesh.pointIds.emplace_back(name, std::move(out));
}

double signedVolume(const Mesh& m)
{
    double v = 0;
    auto tri = [&](unsigned a, unsigned b, unsigned c) {
        const openvdb::Vec3d pa(m.points[a]), pb(m.points[b]), pc(m.points[c]);
        v += pa.dot(pb.cross(pc)) / 6.0;
    };
    for (const auto& t : m.triangles) tri(t[0], t[1], t[2]);
    for (const auto& q : m.quads) { tri(q[0], q[1], q[2]); tri(q[0], q[2], q[3]); }
    return v;
}

void appendMesh(Mesh& mesh, const Mesh& other, int group)
{
    const unsigned off = unsigned(mesh.points.size());
    const size_t triangles = mesh.triangles.size();
    // Normals and uvs stay only when both meshes have them.
    const bool normals = (off == 0 || mesh.normals.size() == off) &&
                         other.normals.size() == other.points.size() && !other.normals.empty();
    const bool uvs = (triangles == 0 || mesh.triangleUvs.size() == triangles) &&
                     other.triangleUvs.size() == other.triangles.size() && !other.uvs.empty();
    if (normals) {
        mesh.normals.insert(mesh.normals.end(), other.normals.begin(), other.normals.end());
    } else {
        mesh.normals.clear();
    }
    if (uvs) {
        const unsigned uvOff = unsigned(mesh.uvs.size());
        mesh.uvs.insert(mesh.uvs.end(), other.uvs.begin(), other.uvs.end());
        for (auto t : other.triangleUvs) mesh.triangleUvs.push_back(t + openvdb::Vec3I(uvOff));
    } else {
        mesh.uvs.clear();
        mesh.triangleUvs.clear();
    }
    // Point ids stay when both meshes carry the same names (the first mesh sets them).
    bool sameIds = off == 0 || mesh.pointIds.size() == other.pointIds.size();
    for (size_t k = 0; sameIds && off > 0 && k < other.pointIds.size(); ++k) {
        sameIds = mesh.pointIds[k].first == other.pointIds[k].first;
    }
    if (off == 0) {
        mesh.pointIds = other.pointIds;
    } else if (sameIds) {
        for (size_t k = 0; k < other.pointIds.size(); ++k) {
            auto& v = mesh.pointIds[k].second;
            v.insert(v.end(), other.pointIds[k].second.begin(), other.pointIds[k].second.end());
        }
    } else {
        mesh.pointIds.clear();
    }
    mesh.points.insert(mesh.points.end(), other.points.begin(), other.points.end());
    for (auto t : other.triangles) mesh.triangles.push_back(t + openvdb::Vec3I(off));
    for (auto q : other.quads) mesh.quads.push_back(q + openvdb::Vec4I(off));
    if (group >= 0) {
        mesh.triangleGroups.resize(mesh.triangles.size() - other.triangles.size(), -1);
        mesh.quadGroups.resize(mesh.quads.size() - other.quads.size(), -1);
        mesh.triangleGroups.resize(mesh.triangles.size(), group);
        mesh.quadGroups.resize(mesh.quads.size(), group);
    }
}

namespace {

bool hasExt(const std::string& path, const char* ext)
{
    const size_t n = std::strlen(ext);
    if (path.size() < n) return false;
    for (size_t i = 0; i < n; ++i) {
        if (std::tolower(path[path.size() - n + i]) != ext[i]) return false;
    }
    return true;
}

std::string toObj(const Mesh& m)
{
    std::ostringstream os;
    os.imbue(std::locale::classic());
    os << "# rockvdb " << version() << " mesh: " << m.points.size() << " points, "
       << m.triangles.size() << " triangles, " << m.quads.size() << " quads\n";
    os.precision(9);
    for (const auto& p : m.points) os << "v " << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
    const bool normals = m.normals.size() == m.points.size() && !m.normals.empty();
    const bool uvs = !m.uvs.empty() && m.triangleUvs.size() == m.triangles.size();
    for (const auto& n : m.normals) {
        if (normals) os << "vn " << n[0] << ' ' << n[1] << ' ' << n[2] << '\n';
    }
    for (const auto& t : m.uvs) {
        if (uvs) os << "vt " << t[0] << ' ' << t[1] << '\n';
    }
    // A face corner: v, v//vn, v/vt or v/vt/vn.
    auto corner = [&](unsigned v, long vt) {
        os << v + 1;
        if (vt >= 0) os << '/' << vt + 1;
        if (normals) os << (vt >= 0 ? "/" : "//") << v + 1;
    };
    const bool grouped = m.triangleGroups.size() == m.triangles.size() &&
                         m.quadGroups.size() == m.quads.size() &&
                         !(m.triangleGroups.empty() && m.quadGroups.empty());
    std::vector<int> groups{-1};
    if (grouped) {
        groups.assign(m.triangleGroups.begin(), m.triangleGroups.end());
        groups.insert(groups.end(), m.quadGroups.begin(), m.quadGroups.end());
        std::sort(groups.begin(), groups.end());
        groups.erase(std::unique(groups.begin(), groups.end()), groups.end());
    }
    // Faces under `usemtl <name>_<id>` of the first id attribute (its first corner's id).
    const std::vector<int>* faceIds = nullptr;
    std::string idName;
    if (!m.pointIds.empty() && m.pointIds[0].second.size() == m.points.size()) {
        faceIds = &m.pointIds[0].second;
        idName = m.pointIds[0].first;
    }
    long current = LONG_MIN;
    auto material = [&](long id) {
        if (!faceIds) return;
        if (id == current) return;
        current = id;
        os << "usemtl " << idName << '_' << (id < 0 ? std::string("none") : std::to_string(id)) << '\n';
    };
    for (int g : groups) {
        if (grouped) os << "o " << m.groupName << '_' << g << '\n';
        // One smoothing group: importers (Blender's) otherwise shade the faces flat and split
        // every vertex per face on export (glTF: 15 360 instead of 3 060 for one rock).
        os << "s 1\n";
        current = LONG_MIN;
        // The group's faces (quads after triangles), by id when there are ids: one usemtl
        // each, not one per change along volumeToMesh's order.
        std::vector<std::pair<long, long>> faces; // (id, index; quads as -1 - index)
        // A face's id: the one most of its corners hold (the first corner's on a tie).
        auto faceId = [&](const unsigned* v, int n) -> long {
            if (!faceIds) return 0L;
            long best = (*faceIds)[v[0]];
            int bestCount = 0;
            for (int a = 0; a < n; ++a) {
                int c = 0;
                for (int b = 0; b < n; ++b) c += (*faceIds)[v[b]] == (*faceIds)[v[a]];
                if (c > bestCount) { bestCount = c; best = (*faceIds)[v[a]]; }
            }
            return best;
        };
        for (size_t i = 0; i < m.triangles.size(); ++i) {
            if (grouped && m.triangleGroups[i] != g) continue;
            const unsigned v[3] = {m.triangles[i][0], m.triangles[i][1], m.triangles[i][2]};
            faces.emplace_back(faceId(v, 3), long(i));
        }
        for (size_t i = 0; i < m.quads.size(); ++i) {
            if (grouped && m.quadGroups[i] != g) continue;
            const unsigned v[4] = {m.quads[i][0], m.quads[i][1], m.quads[i][2], m.quads[i][3]};
            faces.emplace_back(faceId(v, 4), -1L - long(i));
        }
        if (faceIds) {
            std::stable_sort(faces.begin(), faces.end(),
                             [](const auto& a, const auto& b) { return a.first < b.first; });
        }
        for (const auto& [id, f] : faces) {
            if (f >= 0) {
                const size_t i = size_t(f);
                const auto& t = m.triangles[i];
                material(id);
                os << 'f';
                for (int k = 0; k < 3; ++k) {
                    os << ' ';
                    corner(t[k], uvs ? long(m.triangleUvs[i][k]) : -1L);
                }
            } else {
                const auto& q = m.quads[size_t(-1L - f)];
                material(id);
                os << 'f';
                for (int k = 0; k < 4; ++k) {
                    os << ' ';
                    corner(q[k], -1L);
                }
            }
            os << '\n';
        }
    }
    return os.str();
}

template<typename T>
void put(std::string& s, T v)
{
    s.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

std::string toPly(const Mesh& m)
{
    const bool normals = m.normals.size() == m.points.size() && !m.normals.empty();
    std::ostringstream h;
    h << "ply\nformat binary_little_endian 1.0\ncomment rockvdb " << version() << "\n"
      << "element vertex " << m.points.size() << "\nproperty float x\nproperty float y\n"
      << "property float z\n"
      << (normals ? "property float nx\nproperty float ny\nproperty float nz\n" : "");
    std::vector<const std::vector<int>*> ids;
    for (const auto& [name, v] : m.pointIds) {
        if (v.size() != m.points.size()) continue;
        h << "property int " << name << "\n";
        ids.push_back(&v);
    }
    h << "element face " << m.triangles.size() + m.quads.size()
      << "\nproperty list uchar int vertex_indices\n";
    const bool grouped = m.triangleGroups.size() == m.triangles.size() &&
                         m.quadGroups.size() == m.quads.size() &&
                         !(m.triangleGroups.empty() && m.quadGroups.empty());
    if (grouped) h << "property int " << m.groupName << "\n";
    h << "end_header\n";
    std::string s = h.str();
    s.reserve(s.size() + m.points.size() * 12 + m.triangles.size() * 13 + m.quads.size() * 17);
    for (size_t i = 0; i < m.points.size(); ++i) {
        const auto& p = m.points[i];
        put(s, p[0]); put(s, p[1]); put(s, p[2]);
        if (normals) { put(s, m.normals[i][0]); put(s, m.normals[i][1]); put(s, m.normals[i][2]); }
        for (const auto* v : ids) put(s, int32_t((*v)[i]));
    }
    for (size_t i = 0; i < m.triangles.size(); ++i) {
        put(s, uint8_t(3));
        for (int k = 0; k < 3; ++k) put(s, int32_t(m.triangles[i][k]));
        if (grouped) put(s, int32_t(m.triangleGroups[i]));
    }
    for (size_t i = 0; i < m.quads.size(); ++i) {
        put(s, uint8_t(4));
        for (int k = 0; k < 4; ++k) put(s, int32_t(m.quads[i][k]));
        if (grouped) put(s, int32_t(m.quadGroups[i]));
    }
    return s;
}

} // namespace

UpAxis upAxisFromString(const std::string& s, const std::string& what)
{
    if (s == "z" || s == "Z") return UpAxis::Z;
    if (s == "y" || s == "Y") return UpAxis::Y;
    fail<ValueError>(what, " must be z or y (got '", s, "')");
}

void toZUp(Mesh& mesh, UpAxis up)
{
    if (up == UpAxis::Z) return;
    for (auto& p : mesh.points) p = openvdb::Vec3s(p[0], -p[2], p[1]);
    for (auto& n : mesh.normals) n = openvdb::Vec3s(n[0], -n[2], n[1]);
}

void fromZUp(Mesh& mesh, UpAxis up)
{
    if (up == UpAxis::Z) return;
    for (auto& p : mesh.points) p = openvdb::Vec3s(p[0], p[2], -p[1]);
    for (auto& n : mesh.normals) n = openvdb::Vec3s(n[0], n[2], -n[1]);
}

void writeMesh(const Mesh& mesh, const std::string& path, UpAxis up)
{
    if (!(path == "-" || hasExt(path, ".obj") || hasExt(path, ".ply"))) {
        fail<ValueError>("mesh: output '", path, "' must end in .obj or .ply");
    }
    const Mesh* out = &mesh;
    Mesh rotated;
    if (up != UpAxis::Z) {
        rotated = mesh;
        fromZUp(rotated, up);
        out = &rotated;
    }
    if (hasExt(path, ".ply")) return writeFileAtomic(path, toPly(*out));
    writeFileAtomic(path, toObj(*out));
}

namespace {

std::string lowerExtension(const std::string& path)
{
    const auto dot = path.find_last_of('.');
    std::string ext = dot == std::string::npos ? "" : path.substr(dot + 1);
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

// @a idx counts from 0; @a base is how the file counts (OBJ from 1), for the message.
void addPolygon(Mesh& m, const std::vector<int>& idx, const std::string& where, int base = 0)
{
    if (idx.size() < 3) fail<ValueError>(where, ": a face needs at least 3 vertices");
    for (int i : idx) {
        if (i < 0 || size_t(i) >= m.points.size()) {
            fail<ValueError>(where, ": vertex index ", int64_t(i) + base, " out of range (",
                             m.points.size(), " vertices", base ? ", counted from 1)" : ")");
        }
    }
    for (size_t k = 1; k + 1 < idx.size(); ++k) {
        m.triangles.emplace_back(unsigned(idx[0]), unsigned(idx[k]), unsigned(idx[k + 1]));
    }
}

Mesh readObj(const std::string& path, std::istream& in)
{
    Mesh m;
    std::string line;
    int lineNo = 0;
    while (std::getline(in, line)) {
        ++lineNo;
        std::istringstream ls(line);
        std::string tag;
        ls >> tag;
        const std::string where = path + ":" + std::to_string(lineNo);
        if (tag == "v") {
            double x, y, z;
            if (!(ls >> x >> y >> z)) fail<ValueError>(where, ": malformed vertex");
            m.points.emplace_back(float(x), float(y), float(z));
        } else if (tag == "f") {
            std::vector<int> idx;
            std::string tok;
            while (ls >> tok) {
                int i = 0;
                try {
                    i = std::stoi(tok.substr(0, tok.find('/')));
                } catch (const std::exception&) {
                    fail<ValueError>(where, ": malformed face index '", tok, "'");
                }
                idx.push_back(i > 0 ? i - 1 : int(m.points.size()) + i);
            }
            addPolygon(m, idx, where, 1);
        }
    }
    return m;
}

Mesh readStl(const std::string& path, const std::string& bytes)
{
    Mesh m;
    std::map<std::array<float, 3>, unsigned> weld;
    auto vertex = [&](float x, float y, float z) {
        const std::array<float, 3> key{{x, y, z}};
        auto it = weld.find(key);
        if (it != weld.end()) return it->second;
        const unsigned i = unsigned(m.points.size());
        m.points.emplace_back(x, y, z);
        weld.emplace(key, i);
        return i;
    };
    const bool ascii = bytes.compare(0, 5, "solid") == 0 &&
                       bytes.find("facet", 0) != std::string::npos;
    if (ascii) {
        std::istringstream in(bytes);
        std::string tok;
        std::vector<unsigned> tri;
        while (in >> tok) {
            if (tok != "vertex") continue;
            float x, y, z;
            if (!(in >> x >> y >> z)) fail<ValueError>(path, ": malformed STL vertex");
            tri.push_back(vertex(x, y, z));
            if (tri.size() == 3) {
                m.triangles.emplace_back(tri[0], tri[1], tri[2]);
                tri.clear();
            }
        }
        return m;
    }
    if (bytes.size() < 84) fail<ValueError>(path, ": truncated binary STL");
    uint32_t n = 0;
    std::memcpy(&n, bytes.data() + 80, 4);
    if (bytes.size() < 84 + size_t(n) * 50) fail<ValueError>(path, ": truncated binary STL (", n, " triangles announced)");
    for (uint32_t t = 0; t < n; ++t) {
        const char* f = bytes.data() + 84 + size_t(t) * 50 + 12;
        float v[9];
        std::memcpy(v, f, sizeof v);
        m.triangles.emplace_back(vertex(v[0], v[1], v[2]), vertex(v[3], v[4], v[5]),
                                 vertex(v[6], v[7], v[8]));
    }
    return m;
}

Mesh readPly(const std::string& path, const std::string& bytes)
{
    const size_t end = bytes.find("end_header");
    if (bytes.compare(0, 3, "ply") != 0 || end == std::string::npos) {
        fail<ValueError>(path, ": not a PLY file");
    }
    std::istringstream head(bytes.substr(0, end));
    std::string line, format;
    size_t nv = 0, nf = 0;
    std::vector<std::string> vprops; // vertex property types, in order
    std::vector<std::string> vnames;
    std::string countType = "uchar", indexType = "int", section;
    while (std::getline(head, line)) {
        std::istringstream ls(line);
        std::string w;
        ls >> w;
        if (w == "format") ls >> format;
        else if (w == "element") {
            size_t n;
            ls >> section >> n;
            if (section == "vertex") nv = n;
            else if (section == "face") nf = n;
        } else if (w == "property") {
            std::string t;
            ls >> t;
            if (section == "vertex") {
                std::string name;
                ls >> name;
                vprops.push_back(t);
                vnames.push_back(name);
            } else if (section == "face" && t == "list") {
                ls >> countType >> indexType;
            }
        }
    }
    size_t pos = bytes.find('\n', end);
    if (pos == std::string::npos) fail<ValueError>(path, ": truncated PLY header");
    ++pos;
    const int ix = int(std::find(vnames.begin(), vnames.end(), "x") - vnames.begin());
    if (ix + 2 >= int(vnames.size()) || vnames[size_t(ix) + 1] != "y" || vnames[size_t(ix) + 2] != "z") {
        fail<ValueError>(path, ": PLY vertices need consecutive x y z properties");
    }
    Mesh m;
    if (format == "ascii") {
        std::istringstream in(bytes.substr(pos));
        for (size_t i = 0; i < nv; ++i) {
            std::vector<double> v(vprops.size());
            for (double& d : v) {
                if (!(in >> d)) fail<ValueError>(path, ": truncated PLY vertex list");
            }
            m.points.emplace_back(float(v[size_t(ix)]), float(v[size_t(ix) + 1]), float(v[size_t(ix) + 2]));
        }
        for (size_t f = 0; f < nf; ++f) {
            int k;
            if (!(in >> k) || k < 0 || k > 1000) fail<ValueError>(path, ": malformed PLY face");
            std::vector<int> idx(size_t(k), 0);
            for (int& i : idx) {
                if (!(in >> i)) fail<ValueError>(path, ": truncated PLY face list (face ", f, ")");
            }
            addPolygon(m, idx, path + ": face " + std::to_string(f));
        }
        return m;
    }
    if (format != "binary_little_endian") fail<ValueError>(path, ": PLY format '", format, "' unsupported");
    auto size = [&](const std::string& t) -> size_t {
        if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
        if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
        if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
        if (t == "double" || t == "float64") return 8;
        fail<ValueError>(path, ": PLY type '", t, "' unsupported");
    };
    auto read = [&](const std::string& t, size_t& at) -> double {
        const size_t n = size(t);
        if (at + n > bytes.size()) fail<ValueError>(path, ": truncated PLY data");
        const char* p = bytes.data() + at;
        at += n;
        if (t == "float" || t == "float32") { float v; std::memcpy(&v, p, 4); return v; }
        if (t == "double" || t == "float64") { double v; std::memcpy(&v, p, 8); return v; }
        if (n == 1) return t[0] == 'u' ? double(uint8_t(*p)) : double(int8_t(*p));
        if (n == 2) { int16_t v; std::memcpy(&v, p, 2); return t[0] == 'u' ? double(uint16_t(v)) : double(v); }
        int32_t v;
        std::memcpy(&v, p, 4);
        return t[0] == 'u' ? double(uint32_t(v)) : double(v);
    };
    size_t at = pos;
    for (size_t i = 0; i < nv; ++i) {
        std::vector<double> v(vprops.size());
        for (size_t q = 0; q < v.size(); ++q) v[q] = read(vprops[q], at);
        m.points.emplace_back(float(v[size_t(ix)]), float(v[size_t(ix) + 1]), float(v[size_t(ix) + 2]));
    }
    for (size_t f = 0; f < nf; ++f) {
        // The count is the file's word: check it against what is left before allocating (a
        // 'uint' count of 2e9 in a 300-byte file asked for 8 GB; fuzz_mesh found it).
        const double k = read(countType, at);
        if (!(k >= 0 && k <= 1000)) fail<ValueError>(path, ": malformed PLY face ", f, ": it announces ",
                                                   std::abs(k) < 1e18 ? std::to_string(int64_t(k)) : std::to_string(k),
                                                   " vertices (at most 1000)");
        if (at + size_t(k) * size(indexType) > bytes.size()) fail<ValueError>(path, ": truncated PLY data");
        std::vector<int> idx(static_cast<size_t>(k));
        for (int& i : idx) {
            const double v = read(indexType, at); // a 'uint' index of 4e9 does not fit an int
            if (!(v >= 0 && v < double(nv))) {
                fail<ValueError>(path, ": face ", f, ": vertex index ", std::to_string(int64_t(v)), " out of range (",
                                 nv, " vertices)");
            }
            i = int(v);
        }
        addPolygon(m, idx, path + ": face " + std::to_string(f));
    }
    return m;
}

} // namespace

Mesh readMesh(const std::string& path, UpAxis up)
{
    std::ifstream in(path, std::ios::binary);
    if (!in) fail<IoError>("cannot read mesh ", path);
    std::ostringstream ss;
    ss << in.rdbuf();
    const std::string bytes = ss.str();
    const std::string ext = lowerExtension(path);
    Mesh m;
    if (ext == "obj") {
        std::istringstream text(bytes);
        m = readObj(path, text);
    } else if (ext == "stl") {
        m = readStl(path, bytes);
    } else if (ext == "ply") {
        m = readPly(path, bytes);
    } else {
        fail<ValueError>("mesh ", path, ": unknown extension (use .obj, .stl or .ply)");
    }
    if (m.triangles.empty()) fail<ValueError>("mesh ", path, " has no faces");
    toZUp(m, up);
    return m;
}

void requireClosed(const Mesh& mesh, const std::string& what)
{
    // Directed edges: a closed, consistently oriented surface uses each once, and its twin once.
    std::map<std::pair<unsigned, unsigned>, int> edges;
    auto add = [&](unsigned a, unsigned b) { ++edges[{a, b}]; };
    for (const auto& t : mesh.triangles) {
        add(t[0], t[1]);
        add(t[1], t[2]);
        add(t[2], t[0]);
    }
    for (const auto& q : mesh.quads) {
        add(q[0], q[1]);
        add(q[1], q[2]);
        add(q[2], q[3]);
        add(q[3], q[0]);
    }
    size_t open = 0, repeated = 0;
    for (const auto& e : edges) {
        if (e.second > 1) ++repeated;
        if (!edges.count({e.first.second, e.first.first})) ++open;
    }
    if (open || repeated) {
        fail<ValueError>(what, ": the mesh is not closed (", open, " boundary edges, ", repeated,
                         " edges used twice in one direction); a support needs a closed, "
                         "consistently oriented surface");
    }
}

openvdb::FloatGrid::Ptr meshToLevelSet(const Mesh& mesh, double voxelSize, double exterior,
                                       double interior)
{
    auto xf = openvdb::math::Transform::createLinearTransform(voxelSize);
    std::vector<openvdb::Vec3s> pts(mesh.points.size());
    for (size_t i = 0; i < pts.size(); ++i) pts[i] = xf->worldToIndex(mesh.points[i]);
    std::vector<openvdb::Vec4I> polys;
    polys.reserve(mesh.triangles.size() + mesh.quads.size());
    for (const auto& t : mesh.triangles) {
        polys.emplace_back(t[0], t[1], t[2], openvdb::util::INVALID_IDX);
    }
    for (const auto& q : mesh.quads) polys.push_back(q);
    openvdb::tools::QuadAndTriangleDataAdapter<openvdb::Vec3s, openvdb::Vec4I> mesher(pts, polys);
    auto grid = openvdb::tools::meshToVolume<openvdb::FloatGrid>(mesher, *xf, float(exterior),
                                                                float(interior));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    return grid;
}

} // namespace rockvdb
