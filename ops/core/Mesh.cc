#include "Mesh.h"

#include "Error.h"
#include "VdbIO.h"

#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <cctype>
#include <cstring>
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
    for (int g : groups) {
        if (grouped) os << "o " << m.groupName << '_' << g << '\n';
        for (size_t i = 0; i < m.triangles.size(); ++i) {
            if (grouped && m.triangleGroups[i] != g) continue;
            const auto& t = m.triangles[i];
            os << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
        }
        for (size_t i = 0; i < m.quads.size(); ++i) {
            if (grouped && m.quadGroups[i] != g) continue;
            const auto& q = m.quads[i];
            os << "f " << q[0] + 1 << ' ' << q[1] + 1 << ' ' << q[2] + 1 << ' ' << q[3] + 1 << '\n';
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
    std::ostringstream h;
    h << "ply\nformat binary_little_endian 1.0\ncomment rockvdb " << version() << "\n"
      << "element vertex " << m.points.size() << "\nproperty float x\nproperty float y\n"
      << "property float z\nelement face " << m.triangles.size() + m.quads.size()
      << "\nproperty list uchar int vertex_indices\n";
    const bool grouped = m.triangleGroups.size() == m.triangles.size() &&
                         m.quadGroups.size() == m.quads.size() &&
                         !(m.triangleGroups.empty() && m.quadGroups.empty());
    if (grouped) h << "property int " << m.groupName << "\n";
    h << "end_header\n";
    std::string s = h.str();
    s.reserve(s.size() + m.points.size() * 12 + m.triangles.size() * 13 + m.quads.size() * 17);
    for (const auto& p : m.points) { put(s, p[0]); put(s, p[1]); put(s, p[2]); }
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

void writeMesh(const Mesh& mesh, const std::string& path)
{
    if (path == "-" || hasExt(path, ".obj")) return writeFileAtomic(path, toObj(mesh));
    if (hasExt(path, ".ply")) return writeFileAtomic(path, toPly(mesh));
    fail<ValueError>("mesh: output '", path, "' must end in .obj or .ply");
}

} // namespace rockvdb
