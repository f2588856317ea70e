// SPDX-License-Identifier: Apache-2.0
#include "FractalStage.h"

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/fractal/MeshBake.h>

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Points.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/VdbIO.h>

#include <openvdb/tools/GridTransformer.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace rockvdb {
namespace fractal {

using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0)
{
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

Schema<FractalRockParams> makeRockSchema()
{
    using P = FractalRockParams;
    Schema<P> s("fractal", "Fractal rocks: an icosahedron refined by deterministic midpoint "
                           "displacement and subdivision damping; one rock, a scatter on a "
                           "ground (count), or a cave carved from a solid.");
    s.add(param("levels", ParamType::Int, "", 2, Range::closed(0, 8),
                "Subdivision levels: 20·16^L triangles (damping) or 20·4^L (midpoint)"),
          [](const P& p) { return json(p.shape.levels); },
          [](P& p, const json& j) { p.shape.levels = j.get<int>(); });
    ParamInfo method = param("method", ParamType::Text, "", "interpolating", Range::any(),
                             "Subdivision damping with the interpolating or approximating "
                             "spline (16 sub-triangles per level, §5), or plain midpoint "
                             "displacement (4)");
    method.choices = {"interpolating", "approximating", "midpoint"};
    s.add(method, [](const P& p) { return json(methodName(p.shape.method)); },
          [](P& p, const json& j) { p.shape.method = methodFromString(j.get<std::string>()); });
    s.add(param("size", ParamType::Reals, "m", json::array({1.0, 0.8, 0.5}), Range::closed(1e-4, 1e4),
                "Extents of the base icosahedron along x, y, z before the rotation", 3),
          [](const P& p) { return json::array({p.size[0], p.size[1], p.size[2]}); },
          [](P& p, const json& j) { p.size = Vec3d(j.at(0), j.at(1), j.at(2)); });
    s.add(param("roughness", ParamType::Real, "", 0.12, Range::closed(0, 2),
                "First level's displacement range / its edge length (later levels: × (ℓ/ℓ0)^H)"),
          [](const P& p) { return json(p.shape.roughness); },
          [](P& p, const json& j) { p.shape.roughness = j.get<double>(); });
    s.add(param("h-up", ParamType::Real, "", 0.65, Range::open(0, 1),
                "Hurst-like H of surfaces facing up (towards 1: smoother; §4, rough tops)"),
          [](const P& p) { return json(p.shape.hUp); },
          [](P& p, const json& j) { p.shape.hUp = j.get<double>(); });
    s.add(param("h-down", ParamType::Real, "", 0.9, Range::open(0, 1),
                "H of surfaces facing down (smooth bottoms)"),
          [](const P& p) { return json(p.shape.hDown); },
          [](P& p, const json& j) { p.shape.hDown = j.get<double>(); });
    s.add(param("h-blend", ParamType::Real, "", 0.5, Range::openClosed(0, 1),
                "H goes from h-down to h-up as the cosine of the angle to the up axis goes "
                "from -b to b"),
          [](const P& p) { return json(p.shape.hBlend); },
          [](P& p, const json& j) { p.shape.hBlend = j.get<double>(); });
    s.add(param("tilt", ParamType::Real, "degrees", 20.0, Range::closed(0, 180),
                "Orientation: a random yaw, then a random tilt up to this (180: any rotation)"),
          [](const P& p) { return json(p.tilt); }, [](P& p, const json& j) { p.tilt = j.get<double>(); });
    s.add(param("center", ParamType::Reals, "m", json::array({0.0, 0.0, 0.0}), Range::closed(-1e7, 1e7),
                "The rock's centre", 3),
          [](const P& p) { return json::array({p.center[0], p.center[1], p.center[2]}); },
          [](P& p, const json& j) { p.center = Vec3d(j.at(0), j.at(1), j.at(2)); });
    s.add(seedRow("Random seed: displacements and orientation (same seed, same bits)"),
          [](const P& p) { return json(p.shape.seed); },
          [](P& p, const json& j) { p.shape.seed = j.get<uint64_t>(); });
    s.member(voxelSizeRow(0.01, "Voxel edge length of the level set"), &P::voxelSize);
    s.member(halfWidthRow(defaultHalfWidth()), &P::halfWidth);
    s.member(param("normal-levels", ParamType::Int, "", 2, Range::closed(1, 4),
                   "Normal map: levels of the finer model its normals come from (§7)"),
             &P::normalLevels);
    s.member(param("normal-map-size", ParamType::Int, "pixels", 256, Range::closed(16, 4096),
                   "Normal map: pixels per cell (the image is 5n × 2n)"), &P::normalMapSize);
    {
        ParamInfo space = param("normal-space", ParamType::Text, "", "object", Range::any(),
                                "Normal map: 'object' (the mesh file's object space: turned with "
                                "its up axis) or 'tangent' (the coarse mesh's tangent frames from "
                                "its UVs, MikkTSpace-style: what glTF and game engines read)");
        space.choices = {"object", "tangent"};
        s.member(space, &P::normalSpace);
    }
    s.member(maxMemoryRow(), &P::maxMemoryGB);
    // Scatter rows (§1: rocks "spatially distributed by another fBm").
    s.member(param("count", ParamType::Int, "", 0, Range::closed(0, 1000000),
                   "Scatter this many rocks on the ground (0: one rock at center; in a scatter, "
                   "rockvdb.fractal_scatter and the Blender add-on, one per density-scale² of area)"), &P::count);
    s.member(param("area", ParamType::Reals, "m", nullptr, Range::closed(-1e7, 1e7),
                   "Scatter area xmin,ymin,xmax,ymax (default: the ground's extent; on the "
                   "plane z = 0: -5,-5,5,5)", 4), &P::area);
    s.member(param("size-jitter", ParamType::Real, "", 0.5, Range::halfOpen(0, 1),
                   "Scatter: each rock's size is size x uniform [1 - j, 1]"), &P::sizeJitter);
    s.member(param("aspect-jitter", ParamType::Real, "", 0.3, Range::halfOpen(0, 1),
                   "Scatter: its y and z extents are further x uniform [1 - j, 1]"), &P::aspectJitter);
    s.member(param("density-scale", ParamType::Real, "m", 4.0, Range::above(0),
                   "Scatter: wavelength of the fBm density map"), &P::densityScale);
    s.member(param("density-octaves", ParamType::Int, "", 3, Range::closed(1, 8),
                   "Scatter: octaves of the density map"), &P::densityOctaves);
    s.member(param("density-contrast", ParamType::Real, "", 1.5, Range::closed(0, 16),
                   "Scatter: density = ((1 + fbm)/2)^contrast (0: uniform)"), &P::densityContrast);
    s.member(param("embed", ParamType::Real, "", 0.15, Range::closed(0, 0.9),
                   "Scatter: share of each rock's height sunk below the ground"), &P::embed);
    s.member(param("attempts", ParamType::Int, "", 30, Range::closed(1, 10000),
                   "Scatter: candidates per asked rock before reporting a shortfall"), &P::attempts);
    s.member(param("ground-cell-size", ParamType::Real, "m", 0.1, Range::above(0),
                   "Scatter: sample spacing of a heightfield image ground"), &P::groundCellSize);
    s.member(param("ground-height-scale", ParamType::Real, "", 1.0, Range::closed(-1e6, 1e6),
                   "Scatter: metres per unit of a heightfield image ground"), &P::groundHeightScale);
    s.member(param("ground-grid", ParamType::Text, "", "", Range::any(),
                   "Scatter: level set of a .vdb ground (empty: 'surface', else its only one)"),
             &P::groundGrid);
    s.member(param("material", ParamType::Int, "", -1, Range::halfOpen(-1, 1 << 24),
                   "Scatter: also write grid 'material' holding this id on every rock voxel (to "
                   "unite the rocks with other stages' material grids); -1 = none"), &P::material);
    // Caves (§9): a chain of count rocks subtracted from a solid.
    s.member(param("carve-start", ParamType::Reals, "m", nullptr, Range::closed(-1e7, 1e7),
                   "Carve: where the chain of rocks starts (default: the solid's centre)", 3),
             &P::carveStart);
    s.add(param("carve-direction", ParamType::Reals, "", json::array({1.0, 0.0, 0.0}),
                Range::closed(-1e6, 1e6), "Carve: the chain's initial direction", 3),
          [](const P& p) { return json::array({p.carveDirection[0], p.carveDirection[1], p.carveDirection[2]}); },
          [](P& p, const json& j) { p.carveDirection = Vec3d(j.at(0), j.at(1), j.at(2)); });
    s.member(param("carve-wander", ParamType::Real, "", 0.35, Range::closed(0, 4),
                   "Carve: how far each step turns (a random unit vector times this, added to "
                   "the direction)"), &P::carveWander);
    s.rule([](const P& p) {
        if (!(p.carveDirection.length() > 0)) fail<ValueError>("fractal: carve-direction must not be zero");
        if (p.area) {
            const auto& a = *p.area;
            if (!(a[2] > a[0] && a[3] > a[1])) {
                fail<ValueError>("fractal: area needs xmin < xmax and ymin < ymax (got ", a[0], ",",
                                 a[1], ",", a[2], ",", a[3], ")");
            }
        }
    });
    // Front-ends' groups (the Blender add-on's sub-panels); the rest is Shape.
    s.group("Placement", {"center", "count", "area", "size-jitter", "aspect-jitter",
                          "density-scale", "density-octaves", "density-contrast", "embed",
                          "attempts", "material"});
    s.group("Input", {"ground-cell-size", "ground-height-scale", "ground-grid"});
    s.group("Normal map", {"normal-levels", "normal-map-size", "normal-space"});
    s.group("Carve", {"carve-start", "carve-direction", "carve-wander"});
    return s;
}

double memoryLimit(double gb) { return memoryLimitBytes(gb * 1e9); }

// Surface area of the ellipsoid of semi-axes a, b, c (Thomsen's formula, within ~1%): the
// memory estimates' band voxels are about twice it (displacements) / dx² × the band's width.
double ellipsoidArea(const Vec3d& e)
{
    const double a = e[0], b = e[1], c = e[2];
    return 4 * M_PI * std::pow((std::pow(a * b, 1.6) + std::pow(a * c, 1.6) + std::pow(b * c, 1.6)) / 3, 1 / 1.6);
}

// Where the texel (u, v) of UvLayout falls: base face, and the barycentric (a, b) of the
// point on it (the inverse of UvLayout::uv, gutter included, clamped onto the face).
struct FacePoint
{
    int face;
    double a, b;
};

FacePoint texelToFace(double u, double v, const UvLayout& layout)
{
    const double r = (2.0 - std::sqrt(2.0)) / 2.0, s = 1.0 - layout.gutter / r;
    const int cx = std::min(4, int(u * 5)), cy = std::min(1, int(v * 2));
    double x = u * 5 - cx, y = v * 2 - cy;
    const bool lower = x + y <= 1.0;
    const double ic = lower ? r : 1.0 - r;
    x = ic + (x - ic) / s;
    y = ic + (y - ic) / s;
    double a = lower ? x : 1.0 - x, b = lower ? y : 1.0 - y;
    a = std::max(0.0, a);
    b = std::max(0.0, b);
    if (a + b > 1.0) {
        const double sum = a + b;
        a /= sum;
        b /= sum;
    }
    return {(cy * 5 + cx) * 2 + (lower ? 0 : 1), a, b};
}

// The lattice triangle of a base face of N steps holding (a, b): its three lattice points
// (i, j) and their barycentric weights.
struct LatticeHit
{
    std::array<std::pair<int, int>, 3> at;
    std::array<double, 3> w;
};

LatticeHit latticeHit(uint32_t N, double a, double b)
{
    const double fa = a * N, fb = b * N;
    int i = std::min(int(N) - 1, int(std::floor(fa))), j = std::min(int(N) - 1, int(std::floor(fb)));
    if (i + j > int(N) - 1) {
        // On the far edge: step back into the last row of upright triangles.
        if (i > 0) --i; else --j;
    }
    const double da = fa - i, db = fb - j;
    if (da + db <= 1.0 || i + j + 2 > int(N)) {
        return {{{{i, j}, {i + 1, j}, {i, j + 1}}}, {1.0 - da - db, da, db}};
    }
    return {{{{i + 1, j + 1}, {i + 1, j}, {i, j + 1}}}, {da + db - 1.0, 1.0 - db, 1.0 - da}};
}

// Lattice point (i, j) of base face @a face among the 20 faces' points of a lattice of N steps.
size_t latticeIndex(uint32_t N, int face, int i, int j)
{
    const size_t P = size_t(N + 1) * (N + 2) / 2;
    return size_t(face) * P + size_t(j) * (N + 1) - size_t(j) * (j - 1) / 2 + size_t(i);
}

// Per base face, the vertex at each lattice point (latticeIndex).
std::vector<unsigned> latticeVertices(const RockMesh& m)
{
    std::vector<unsigned> at(20 * size_t(m.lattice + 1) * (m.lattice + 2) / 2, ~0u);
    for (size_t t = 0; t < m.triangles.size(); ++t) {
        const auto& c = m.corners[t];
        for (int q = 0; q < 3; ++q) {
            at[latticeIndex(m.lattice, m.baseFace[t], int(c[size_t(2 * q)]), int(c[size_t(2 * q + 1)]))] =
                m.triangles[t][q];
        }
    }
    return at;
}

// Tangent frames of the coarse mesh as a tangent-space consumer builds them (MikkTSpace:
// Blender, glTF viewers, game engines): per triangle the directions of increasing u and v
// on the surface, summed at each corner weighted by the corner's angle, per UV island (every
// base face is its own island, so a corner's frame is its face's), made orthogonal to the
// vertex normal; the bitangent is sign · N × T. Per lattice point of each base face: T and
// the sign.
struct TangentFrames
{
    std::vector<Vec3d> tangent;
    std::vector<double> sign;
};

TangentFrames tangentFrames(const RockMesh& m, const std::vector<Vec3d>& world,
                            const std::vector<Vec3d>& normals, const std::vector<unsigned>& vertex,
                            const UvLayout& layout)
{
    const uint32_t N = m.lattice;
    std::vector<Vec3d> T(vertex.size(), Vec3d(0.0)), B(vertex.size(), Vec3d(0.0));
    for (size_t t = 0; t < m.triangles.size(); ++t) {
        const int f = m.baseFace[t];
        const auto& c = m.corners[t];
        std::array<Vec3d, 3> p;
        std::array<openvdb::Vec2d, 3> uv;
        std::array<size_t, 3> k;
        for (int q = 0; q < 3; ++q) {
            const int i = int(c[size_t(2 * q)]), j = int(c[size_t(2 * q + 1)]);
            p[size_t(q)] = world[m.triangles[t][q]];
            uv[size_t(q)] = layout.uv(f, double(i) / N, double(j) / N);
            k[size_t(q)] = latticeIndex(N, f, i, j);
        }
        const Vec3d e1 = p[1] - p[0], e2 = p[2] - p[0];
        const double du1 = uv[1][0] - uv[0][0], dv1 = uv[1][1] - uv[0][1];
        const double du2 = uv[2][0] - uv[0][0], dv2 = uv[2][1] - uv[0][1];
        const double det = du1 * dv2 - du2 * dv1;
        if (std::abs(det) < 1e-20) continue;
        const Vec3d tu = (e1 * dv2 - e2 * dv1) / det, tv = (e2 * du1 - e1 * du2) / det;
        for (int q = 0; q < 3; ++q) {
            const Vec3d a = p[size_t((q + 1) % 3)] - p[size_t(q)], b = p[size_t((q + 2) % 3)] - p[size_t(q)];
            const double la = a.length(), lb = b.length();
            if (la <= 0 || lb <= 0) continue;
            const double angle = std::acos(std::clamp(a.dot(b) / (la * lb), -1.0, 1.0));
            T[k[size_t(q)]] += tu * angle;
            B[k[size_t(q)]] += tv * angle;
        }
    }
    TangentFrames out{std::vector<Vec3d>(vertex.size(), Vec3d(1, 0, 0)), std::vector<double>(vertex.size(), 1.0)};
    for (size_t k = 0; k < T.size(); ++k) {
        if (vertex[k] == ~0u) continue;
        const Vec3d& n = normals[vertex[k]];
        Vec3d t = T[k] - n * n.dot(T[k]);
        const double len = t.length();
        if (len <= 1e-12) continue;
        t /= len;
        out.tangent[k] = t;
        out.sign[k] = n.cross(t).dot(B[k]) < 0.0 ? -1.0 : 1.0;
    }
    return out;
}

// The normal map of the finer model (§7), laid out as UvLayout: per texel the normal of the
// fine mesh (its vertex normals blended across the fine triangle), in object space (rockvdb's
// frame) or in the tangent frame of the coarse mesh there (interpolated as a shader does).
void normalMap(const RockMesh& coarse, const std::vector<Vec3d>& coarseWorld, const RockMesh& fine,
               const std::vector<Vec3d>& fineWorld, int cell, bool tangentSpace,
               std::vector<float>& rgb, int& width, int& height, Task& task)
{
    const std::vector<Vec3d> normals = vertexNormals(fineWorld, fine.triangles);
    const std::vector<unsigned> fineAt = latticeVertices(fine);
    const UvLayout layout;
    std::vector<Vec3d> coarseNormals;
    std::vector<unsigned> coarseAt;
    TangentFrames frames;
    if (tangentSpace) {
        coarseNormals = vertexNormals(coarseWorld, coarse.triangles);
        coarseAt = latticeVertices(coarse);
        frames = tangentFrames(coarse, coarseWorld, coarseNormals, coarseAt, layout);
    }
    width = 5 * cell;
    height = 2 * cell;
    rgb.assign(size_t(width) * size_t(height) * 3, 0.0f);
    parallelFor(task, size_t(height), 8, [&](size_t row) {
        const double v = 1.0 - (double(row) + 0.5) / height;
        for (int col = 0; col < width; ++col) {
            const FacePoint fp = texelToFace((col + 0.5) / width, v, layout);
            const LatticeHit hit = latticeHit(fine.lattice, fp.a, fp.b);
            Vec3d n(0.0);
            for (int q = 0; q < 3; ++q) {
                const auto [i, j] = hit.at[size_t(q)];
                n += normals[fineAt[latticeIndex(fine.lattice, fp.face, i, j)]] * hit.w[size_t(q)];
            }
            double len = n.length();
            if (len > 0) n /= len;
            if (tangentSpace) {
                // The shader's frame: T and N blended across the coarse triangle, B = s·N×T;
                // stored are the coefficients c with c_x T + c_y B + c_z N ∥ n.
                const LatticeHit ch = latticeHit(coarse.lattice, fp.a, fp.b);
                Vec3d t(0.0), nn(0.0);
                double sign = 0;
                for (int q = 0; q < 3; ++q) {
                    const auto [i, j] = ch.at[size_t(q)];
                    const size_t k = latticeIndex(coarse.lattice, fp.face, i, j);
                    t += frames.tangent[k] * ch.w[size_t(q)];
                    nn += coarseNormals[coarseAt[k]] * ch.w[size_t(q)];
                    sign += frames.sign[k] * ch.w[size_t(q)];
                }
                const Vec3d b = nn.cross(t) * (sign < 0 ? -1.0 : 1.0);
                openvdb::math::Mat3d M(t[0], b[0], nn[0], t[1], b[1], nn[1], t[2], b[2], nn[2]);
                const double det = M.det();
                const Vec3d c = std::abs(det) > 1e-12 ? M.inverse() * n : Vec3d(0, 0, 1);
                len = c.length();
                n = len > 0 ? c / len : Vec3d(0, 0, 1);
            }
            float* out = &rgb[(row * size_t(width) + size_t(col)) * 3];
            for (int c = 0; c < 3; ++c) out[c] = float(0.5 * n[c] + 0.5);
        }
    });
}

} // namespace

const Schema<FractalRockParams>& rockSchema()
{
    static const Schema<FractalRockParams> s = makeRockSchema();
    return s;
}

FractalRockParams::FractalRockParams() { rockSchema().reset(*this); }

const std::vector<std::string>& scatterRows()
{
    static const std::vector<std::string> rows = {
        "count", "area", "size-jitter", "aspect-jitter", "density-scale", "density-octaves",
        "density-contrast", "embed", "attempts", "ground-cell-size", "ground-height-scale",
        "ground-grid", "material"};
    return rows;
}

const std::vector<std::string>& groundRows()
{
    static const std::vector<std::string> rows = {
        "area", "density-scale", "density-octaves", "density-contrast", "embed", "attempts",
        "ground-cell-size", "ground-height-scale", "ground-grid", "material"};
    return rows;
}

const std::vector<std::string>& carveRows()
{
    static const std::vector<std::string> rows = {"carve-start", "carve-direction", "carve-wander"};
    return rows;
}

const std::vector<std::string>& singleRockRows()
{
    static const std::vector<std::string> rows = {"center", "normal-levels", "normal-map-size", "normal-space"};
    return rows;
}

namespace {

// A row of the other mode must keep its default: a value there would be ignored.
void requireDefaults(const FractalRockParams& p, const std::vector<std::string>& rows,
                     const char* why)
{
    const json given = rockSchema().toJson(p), defaults = rockSchema().toJson(FractalRockParams());
    for (const auto& name : rows) {
        if (name == "count") continue;
        if (given.value(name, json()) != defaults.value(name, json())) {
            fail<ValueError>("fractal: ", name, " ", why);
        }
    }
}

} // namespace

void writeNormalMap(const std::string& path, int width, int height, std::vector<float> rgb,
                    const std::string& space, UpAxis up)
{
    if (space != "object" && space != "tangent") {
        fail<ValueError>("fractal: normal-space must be 'object' or 'tangent' (got '", space, "')");
    }
    std::string name = space;
    if (space == "object") {
        name = up == UpAxis::Y ? "object, y up" : "object, z up";
        if (up == UpAxis::Y) {
            // The file's (x, y, z) is rockvdb's (x, z, −y), as fromZUp turns the mesh.
            for (size_t k = 0; k + 2 < rgb.size(); k += 3) {
                const float y = rgb[k + 1], z = rgb[k + 2];
                rgb[k + 1] = z;
                rgb[k + 2] = 1.0f - y;
            }
        }
    }
    writeRgbExr(path, width, height, rgb,
                {{"rockvdb:normal_space", name}, {"rockvdb:normal_encoding", "rgb = n / 2 + 1 / 2"}});
}

const char* normalMapHelp()
{
    return "Normal map (§7): an RGB float EXR of the normals of a model normal-levels finer, "
           "averaged per vertex, stored as n/2 + 1/2; --normal-space object: in the mesh "
           "file's object space (rockvdb's z up, or turned with the mesh by --mesh-up y, as "
           "Blender's OBJ importer keeps it), tangent: in the OBJ's tangent frames (per-vertex "
           "tangents from the UVs, bitangent sign·N×T, as MikkTSpace builds them in Blender and "
           "glTF). The EXR header's rockvdb:normal_space names the space. UV layout (written into the OBJ as vt): the 20 icosahedron faces in 10 "
           "square cells, 5 across and 2 down (the image is 5n x 2n pixels); face 2k and 2k+1 "
           "share cell k (column k mod 5, row k div 5 from the bottom): 2k its lower-left "
           "half, 2k+1 its upper-right half, each shrunk by a 1% gutter.";
}

RockResult runRock(const FractalRockParams& p, bool withLevelSet, bool withNormalMap, Task& task)
{
    rockSchema().validate(p);
    if (p.count != 0) fail<ValueError>("fractal: count is for a scatter (vdb_fractal_rock --count, rockvdb.fractal_scatter)");
    requireDefaults(p, scatterRows(), "applies to a scatter (--count N)");
    requireDefaults(p, carveRows(), "applies to a carve (--carve SOLID --count N)");
    const double limit = memoryLimit(p.maxMemoryGB);
    const double bytes = meshBytes(p.shape.levels, p.shape.method);
    if (bytes > limit) {
        fail<ValueError>("fractal: ", p.shape.levels, " levels make ",
                         triangleCount(p.shape.levels, p.shape.method), " triangles (about ",
                         formatBytes(bytes), ", over the ", formatBytes(limit),
                         " limit); use fewer --levels or raise --max-memory");
    }
    if (withNormalMap) {
        const double fine = meshBytes(p.shape.levels + p.normalLevels, p.shape.method);
        if (fine > limit) {
            fail<ValueError>("fractal: the normal map's model (", p.shape.levels + p.normalLevels,
                             " levels) needs about ", formatBytes(fine), ", over the ",
                             formatBytes(limit), " limit; use fewer --normal-levels or --levels");
        }
    }
    const Vec3d extent = p.extent();
    const double dx = p.voxelSize;
    if (withLevelSet) {
        // Band voxels ≈ the rock's area (at most its ellipsoid's, × 2 for the roughness)
        // / dx² × the band's width, ~40 B each in the mesh-to-volume build.
        const double voxels = 2.0 * ellipsoidArea(extent) / (dx * dx) * 2.0 * p.halfWidth;
        if (voxels * 40 > limit) {
            fail<ValueError>("fractal: a ", p.size[0], " m rock at ", dx, " m voxels needs about ",
                             formatBytes(voxels * 40), " (over the ", formatBytes(limit),
                             " limit); use a larger --voxel-size or raise --max-memory");
        }
    }
    RockResult r;
    const std::array<Vec3d, 3> R = randomOrientation(p.shape.seed, p.tilt);
    const double meshShare = withLevelSet ? 0.3 : 0.9;
    task.phase("mesh", withNormalMap ? meshShare * 0.5 : meshShare);
    auto t0 = Clock::now();
    r.rock = buildRock(p.shape, extent, R, task);
    const std::vector<Vec3d> world = toWorld(r.rock, extent, R, p.center);
    r.mesh = rockMesh(r.rock, world, withNormalMap);
    r.stats.meshSeconds = since(t0);
    r.stats.triangles = r.mesh.triangles.size();
    r.stats.vertices = r.mesh.points.size();
    r.stats.volume = signedVolume(r.mesh);
    if (withNormalMap) {
        task.phase("normal map", withLevelSet ? 0.3 : 0.1 + meshShare * 0.5);
        t0 = Clock::now();
        RockShape fineShape = p.shape;
        fineShape.levels += p.normalLevels;
        const RockMesh fine = buildRock(fineShape, extent, R, task);
        normalMap(r.rock, world, fine, toWorld(fine, extent, R, p.center), p.normalMapSize,
                  p.normalSpace == "tangent", r.normalMap,
                  r.normalMapWidth, r.normalMapHeight, task);
        r.stats.normalMapSeconds = since(t0);
    }
    if (withLevelSet) {
        task.phase("level set", withNormalMap ? 0.4 : 0.7);
        t0 = Clock::now();
        r.surface = bakeMeshes({MeshPart{&world, &r.rock.triangles}}, dx, p.halfWidth, true, task);
        task.check();
        r.stats.levelSetSeconds = since(t0);
        r.stats.activeVoxels = size_t(r.surface->activeVoxelCount());
    }
    task.done();
    return r;
}

std::shared_ptr<const Ground> loadGround(const std::string& path, const FractalRockParams& p)
{
    if (path.empty()) return planeGround();
    auto ends = [&](const char* ext) {
        const size_t n = std::strlen(ext);
        if (path.size() < n) return false;
        for (size_t i = 0; i < n; ++i) {
            if (std::tolower(static_cast<unsigned char>(path[path.size() - n + i])) != ext[i]) return false;
        }
        return true;
    };
    if (ends(".vdb")) {
        const openvdb::GridPtrVecPtr grids = readGrids(path);
        const auto grid = findLevelSet(*grids, p.groundGrid, path);
        return levelSetGround(*grid);
    }
    if (ends(".exr") || ends(".png")) {
        return heightfieldGround(std::make_shared<const Heightfield>(
            loadHeightfield(path, p.groundCellSize, p.groundHeightScale)));
    }
    fail<ValueError>("fractal: ground '", path, "' must be a heightfield image (.exr, .png) or a "
                     "level set (.vdb)");
}

ScatterResult runScatter(const FractalRockParams& p, const Ground& ground, bool points,
                         bool withMesh, Task& task)
{
    rockSchema().validate(p);
    requireDefaults(p, singleRockRows(), "applies to a single rock (count 0)");
    requireDefaults(p, carveRows(), "applies to a carve (--carve SOLID)");
    ScatterSettings s;
    if (p.area) {
        s.area = *p.area;
    } else if (auto b = ground.bounds()) {
        s.area = *b;
    } else {
        s.area = {-5.0, -5.0, 5.0, 5.0};
    }
    s.size = p.size;
    // count 0 in a scatter: one rock per density-scale² of the area (the density map's own
    // cell), so a scatter at its defaults scatters some rocks (issue 55).
    const int count = p.count >= 1 ? p.count
        : int(std::max(1.0, std::round((s.area[2] - s.area[0]) * (s.area[3] - s.area[1]) /
                                       (p.densityScale * p.densityScale))));
    s.count = count;
    s.sizeJitter = p.sizeJitter;
    s.aspectJitter = p.aspectJitter;
    s.tilt = p.tilt;
    s.densityScale = p.densityScale;
    s.densityContrast = p.densityContrast;
    s.densityOctaves = p.densityOctaves;
    s.embed = p.embed;
    s.attempts = p.attempts;
    s.shape = p.shape;
    // Memory: every rock's mesh, and the band of their union.
    const double limit = memoryLimit(p.maxMemoryGB);
    const double meshMemory = double(count) * meshBytes(p.shape.levels, p.shape.method);
    const double voxels = double(count) * 2.0 * ellipsoidArea(p.extent()) /
                          (p.voxelSize * p.voxelSize) * 2.0 * p.halfWidth;
    if (meshMemory + voxels * 40 > limit) {
        fail<ValueError>("fractal: ", count, " rocks of ", p.shape.levels, " levels at ",
                         p.voxelSize, " m voxels need about ", formatBytes(meshMemory + voxels * 40),
                         " (over the ", formatBytes(limit), " limit); use fewer --count or "
                         "--levels, a larger --voxel-size, or raise --max-memory");
    }
    ScatterResult r;
    task.phase("place", 0.05);
    r.rocks = placeRocks(s, r.stats, task);

    // Meshes, in parallel; each lowered onto the ground.
    task.phase("meshes", 0.25);
    auto t0 = Clock::now();
    const size_t n = r.rocks.size();
    std::vector<RockMesh> meshes(n);
    std::vector<std::vector<Vec3d>> world(n);
    parallelFor(task, n, 4, [&](size_t i) {
        Placed& rock = r.rocks[i];
        RockShape shape = p.shape;
        shape.seed = rock.seed;
        Task quiet; // the outer task checks between rocks
        meshes[i] = buildRock(shape, rock.extent, rock.rotation, quiet);
        std::vector<Vec3d> w = toWorld(meshes[i], rock.extent, rock.rotation, Vec3d(rock.position[0], rock.position[1], 0.0));
        // Rest: the lowest point relative to the ground under it sits embed · height below.
        double lowest = std::numeric_limits<double>::max(), zmin = lowest, zmax = -lowest;
        for (const Vec3d& q : w) {
            zmin = std::min(zmin, q[2]);
            zmax = std::max(zmax, q[2]);
        }
        for (const Vec3d& q : w) {
            if (q[2] > zmin + 0.5 * (zmax - zmin)) continue; // the lower half can touch
            lowest = std::min(lowest, q[2] - ground.height(q[0], q[1]));
        }
        const double dz = -lowest - p.embed * (zmax - zmin);
        for (Vec3d& q : w) q[2] += dz;
        rock.position[2] = dz;
        world[i] = std::move(w);
    });
    r.stats.meshSeconds = since(t0);

    // Every rock baked alone (MeshBake.h), united leaf by leaf: the level set, and rock_id
    // from the rock nearest each voxel.
    task.phase("level set", 0.7);
    t0 = Clock::now();
    std::vector<MeshPart> parts(n);
    for (size_t i = 0; i < n; ++i) parts[i] = {&world[i], &meshes[i].triangles};
    r.surface = bakeMeshes(parts, p.voxelSize, p.halfWidth, true, task, &r.rockId);
    r.stats.levelSetSeconds = since(t0);
    if (p.material >= 0) {
        r.material = r.rockId->deepCopy();
        r.material->setName("material");
        const float id = float(p.material);
        openvdb::tree::LeafManager<openvdb::FloatTree> leaves(r.material->tree());
        leaves.foreach([id](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
            for (auto it = leaf.beginValueOn(); it; ++it) it.setValue(id);
        });
    }
    if (points) {
        InstancePoints ip;
        std::vector<int32_t> rock(n);
        for (size_t i = 0; i < n; ++i) {
            ip.positions.push_back(r.rocks[i].position);
            const auto q = quaternionOf(r.rocks[i].rotation);
            ip.orient.emplace_back(float(q[0]), float(q[1]), float(q[2]), float(q[3]));
            // pscale · scale = the rock's semi-axes: a piece of radius 1 about the origin (any
            // rock of the artist's, or vdb_fractal_rock --size 1,1,1) copies onto the rock's
            // ellipsoid, x ↦ P + orient·(pscale·scale·x); one piece, variant 0.
            const Vec3d e = r.rocks[i].extent;
            const double ps = std::max({e[0], e[1], e[2]});
            ip.pscale.push_back(float(ps));
            ip.scale.emplace_back(float(e[0] / ps), float(e[1] / ps), float(e[2] / ps));
            ip.variant.push_back(0);
            rock[i] = int32_t(i);
        }
        ip.ints = {{"rock", std::move(rock)}};
        r.points = instancePointsGrid(ip, std::max(p.voxelSize, 0.5 * p.size[0]), "rocks");
    }
    if (withMesh) {
        for (size_t i = 0; i < n; ++i) appendMesh(r.mesh, rockMesh(meshes[i], world[i], false), int(i));
        r.mesh.groupName = "rock";
    }
    task.done();
    return r;
}

CarveResult runCarve(const FractalRockParams& p, const openvdb::FloatGrid& solid, Task& task)
{
    rockSchema().validate(p);
    if (p.count < 1) fail<ValueError>("fractal: a carve needs count >= 1 (the rocks of the chain)");
    requireLevelSet(solid, "carve solid");
    requireDefaults(p, singleRockRows(), "applies to a single rock (count 0)");
    requireDefaults(p, groundRows(), "applies to a scatter on a ground, not a carve");
    const double dx = solid.voxelSize()[0];
    if (p.voxelSize != FractalRockParams().voxelSize && std::abs(p.voxelSize - dx) > 1e-12 * dx) {
        fail<ValueError>("fractal: a carve bakes its rocks on the solid's voxels (", dx,
                         " m); leave voxel-size out (got ", p.voxelSize, ")");
    }
    const double limit = memoryLimit(p.maxMemoryGB);
    const double bytes = double(p.count) * meshBytes(p.shape.levels, p.shape.method);
    if (bytes > limit) {
        fail<ValueError>("fractal: ", p.count, " rocks of ", p.shape.levels, " levels need about ",
                         formatBytes(bytes), " (over the ", formatBytes(limit), " limit)");
    }
    CarveResult r;
    task.phase("chain", 0.2);
    // A random walk: each rock one step (0.6 of the two rocks' mean radii, so neighbours
    // overlap and the cave is one passage) from the last, the direction turned by a random
    // unit vector times the wander.
    Vec3d at;
    if (p.carveStart) {
        at = Vec3d((*p.carveStart)[0], (*p.carveStart)[1], (*p.carveStart)[2]);
    } else {
        const openvdb::CoordBBox box = solid.evalActiveVoxelBoundingBox();
        at = solid.transform().indexToWorld(box.getCenter());
    }
    Vec3d dir = p.carveDirection.unit();
    const uint64_t seed = p.shape.seed;
    std::vector<RockMesh> meshes(size_t(p.count));
    std::vector<std::vector<Vec3d>> world(size_t(p.count));
    double previous = 0;
    for (int i = 0; i < p.count; ++i) {
        task.step(double(i) / p.count);
        Placed rock;
        const uint64_t h = random::hash(seed, 0xca7e, uint64_t(i));
        const double scale = 1.0 - p.sizeJitter * random::uniform(h, 1, 0);
        rock.extent = Vec3d(0.5 * p.size[0] * scale,
                            0.5 * p.size[1] * scale * (1.0 - p.aspectJitter * random::uniform(h, 1, 1)),
                            0.5 * p.size[2] * scale * (1.0 - p.aspectJitter * random::uniform(h, 1, 2)));
        const double radius = (rock.extent[0] + rock.extent[1] + rock.extent[2]) / 3.0;
        if (i > 0) {
            const double z = 2 * random::uniform(h, 2, 0) - 1, phi = 2 * M_PI * random::uniform(h, 2, 1);
            const double sxy = std::sqrt(std::max(0.0, 1 - z * z));
            const Vec3d turn(sxy * std::cos(phi), sxy * std::sin(phi), z);
            const Vec3d d = dir + turn * p.carveWander;
            if (d.length() > 1e-9) dir = d.unit();
            at += dir * (0.6 * (previous + radius));
        }
        previous = radius;
        rock.position = at;
        rock.seed = h;
        rock.rotation = randomOrientation(h, 180.0);
        rock.radius = radius;
        r.rocks.push_back(rock);
    }
    parallelFor(task, r.rocks.size(), 1, [&](size_t i) {
        RockShape shape = p.shape;
        shape.seed = r.rocks[i].seed;
        Task quiet;
        meshes[i] = buildRock(shape, r.rocks[i].extent, r.rocks[i].rotation, quiet);
        world[i] = toWorld(meshes[i], r.rocks[i].extent, r.rocks[i].rotation, r.rocks[i].position);
    });
    task.phase("level set", 0.5);
    std::vector<MeshPart> parts(meshes.size());
    for (size_t i = 0; i < meshes.size(); ++i) parts[i] = {&world[i], &meshes[i].triangles};
    r.cave = bakeMeshes(parts, dx, p.halfWidth, false, task);
    if (r.cave->transform() != solid.transform()) {
        // A solid on another transform (translated, say): the cave resampled onto it.
        auto onSolid = openvdb::FloatGrid::create(r.cave->background());
        onSolid->setTransform(solid.transform().copy());
        onSolid->setGridClass(openvdb::GRID_LEVEL_SET);
        openvdb::tools::resampleToMatch<openvdb::tools::BoxSampler>(*r.cave, *onSolid);
        r.cave = onSolid;
    }
    r.cave->setName("cave");
    task.phase("subtract", 0.3);
    // solid − cave = max(solid, −cave) per voxel over both bands (tools::csgDifferenceCopy
    // gave different bits at 1 and 2 threads), then the flood fill re-signs the tiles the cave
    // emptied.
    r.surface = solid.deepCopy();
    r.surface->tree().topologyUnion(r.cave->tree());
    {
        const float bg = r.surface->background();
        openvdb::tree::LeafManager<openvdb::FloatTree> leaves(r.surface->tree());
        leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
            auto s = solid.getConstAccessor();
            auto c = r.cave->getConstAccessor();
            for (openvdb::Index i = 0; i < openvdb::FloatTree::LeafNodeType::SIZE; ++i) {
                const openvdb::Coord ijk = leaf.offsetToGlobalCoord(i);
                const float v = std::max(s.getValue(ijk), -c.getValue(ijk));
                leaf.setValueOnly(i, std::min(std::max(v, -bg), bg));
            }
        });
        openvdb::tools::signedFloodFill(r.surface->tree());
        openvdb::tools::pruneLevelSet(r.surface->tree());
    }
    task.check();
    r.surface->setName(solid.getName().empty() ? "surface" : solid.getName());
    r.surface->setGridClass(openvdb::GRID_LEVEL_SET);
    task.done();
    return r;
}

namespace {

FractalMode chooseMode(const FractalRockParams& p, const FractalInputs& in)
{
    const bool carve = !in.carvePath.empty() || in.carveGrid;
    const bool ground = !in.groundPath.empty() || in.groundGrid;
    FractalMode mode = in.mode;
    if (mode == FractalMode::Auto) {
        mode = carve ? FractalMode::Carve : p.count > 0 ? FractalMode::Scatter : FractalMode::Rock;
    }
    if (mode == FractalMode::Carve) {
        if (!carve) fail<ValueError>("fractal: a carve needs a solid (a level set .vdb or grid)");
        if (in.normalMap || ground || in.points || in.mesh) {
            fail<ValueError>("fractal: --carve writes the carved solid only (no --normal-map, "
                             "--ground, --points or --mesh)");
        }
    } else if (mode == FractalMode::Scatter) {
        if (in.normalMap) fail<ValueError>("fractal: --normal-map is for a single rock (count 0)");
    } else if (ground || in.points) {
        // (only the CLI reaches these: each Python function takes what its mode reads)
        fail<ValueError>("fractal: --ground and --points are for a scatter (--count N)");
    }
    return mode;
}

json scatterStats(const ScatterStats& s)
{
    return {{"asked", s.asked}, {"placed", s.placed}, {"candidates", s.candidates},
            {"rejected_density", s.rejectedDensity}, {"rejected_overlap", s.rejectedOverlap},
            {"place_seconds", s.placeSeconds}, {"mesh_seconds", s.meshSeconds},
            {"level_set_seconds", s.levelSetSeconds}};
}

void tellScatter(FractalResult& out)
{
    const ScatterStats& s = out.scatter.stats;
    char line[300];
    std::snprintf(line, sizeof line,
                  "placed %zu of %zu rocks (%zu candidates: %zu by density, %zu by overlap); "
                  "place %.3f s, meshes %.3f s, level set %.3f s (%.0f rocks/s)",
                  s.placed, s.asked, s.candidates, s.rejectedDensity, s.rejectedOverlap,
                  s.placeSeconds, s.meshSeconds, s.levelSetSeconds,
                  double(s.placed) / std::max(1e-9, s.placeSeconds + s.meshSeconds + s.levelSetSeconds));
    out.report.push_back(line);
    if (s.placed < s.asked) {
        std::snprintf(line, sizeof line, "warning: only %zu of %zu rocks fit (raise --attempts or "
                      "--area, lower --size or --density-contrast)", s.placed, s.asked);
        out.report.push_back(line);
    }
    out.stats = scatterStats(s);
    openvdb::GridPtrVec grids{out.scatter.rockId};
    if (out.scatter.material) grids.push_back(out.scatter.material);
    grids.push_back(out.scatter.surface);
    out.grids = grids;
}

void tellRock(FractalResult& out, bool normalMap)
{
    const RockStats& s = out.rock.stats;
    char line[300];
    std::snprintf(line, sizeof line,
                  "%zu triangles, %zu vertices, volume %.4f m3; mesh %.4f s, level set %.4f s "
                  "(%zu active voxels)%s",
                  s.triangles, s.vertices, s.volume, s.meshSeconds, s.levelSetSeconds,
                  s.activeVoxels,
                  normalMap ? (", normal map " + std::to_string(s.normalMapSeconds) + " s").c_str() : "");
    out.report.push_back(line);
    out.stats = {{"triangles", s.triangles}, {"vertices", s.vertices}, {"volume", s.volume},
                 {"active_voxels", s.activeVoxels}, {"mesh_seconds", s.meshSeconds},
                 {"level_set_seconds", s.levelSetSeconds},
                 {"normal_map_seconds", s.normalMapSeconds}};
    if (out.rock.surface) out.grids = {out.rock.surface};
}

} // namespace

FractalResult runFractal(const FractalRockParams& p, const FractalInputs& in, Task& task)
{
    FractalResult out;
    out.mode = chooseMode(p, in);
    json source = in.source;
    if (out.mode == FractalMode::Carve) {
        openvdb::FloatGrid::ConstPtr solid = in.carveGrid;
        if (!solid) {
            solid = findLevelSet(*readGrids(in.carvePath), "", in.carvePath);
            source["carve"] = in.carvePath;
        }
        out.carve = runCarve(p, *solid, task);
        char line[200];
        std::snprintf(line, sizeof line, "carved a chain of %zu rocks (%zu cave voxels)",
                      out.carve.rocks.size(), size_t(out.carve.cave->activeVoxelCount()));
        out.report.push_back(line);
        out.stats = {{"rocks", out.carve.rocks.size()},
                     {"cave_voxels", size_t(out.carve.cave->activeVoxelCount())}};
        out.grids = {out.carve.surface, out.carve.cave};
    } else if (out.mode == FractalMode::Scatter) {
        std::shared_ptr<const Ground> ground;
        if (in.groundGrid) {
            requireLevelSet(*in.groundGrid, "fractal ground");
            ground = levelSetGround(*in.groundGrid);
        } else {
            ground = loadGround(in.groundPath, p);
            if (!in.groundPath.empty()) source["ground"] = in.groundPath;
        }
        out.scatter = runScatter(p, *ground, in.points, in.mesh, task);
        tellScatter(out);
    } else {
        out.rock = runRock(p, in.levelSet, in.normalMap, task);
        tellRock(out, in.normalMap);
    }
    // One record on every grid: the table's values, and the inputs of a scatter or carve.
    if (!out.grids.empty()) {
        stampResult(out, kToolName, out.grids,
                    out.mode == FractalMode::Rock ? rockSchema().toJson(p)
                                                  : stageProvenance(rockSchema().toJson(p), source));
        stampExtras(out, kToolName, {out.scatter.points});
    }
    out.stats["phases"] = phasesJson(task);
    return out;
}

} // namespace fractal
} // namespace rockvdb
