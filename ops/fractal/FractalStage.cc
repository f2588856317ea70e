#include "FractalStage.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/VdbIO.h>

#include <openvdb/tools/MeshToVolume.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>

namespace rockvdb {
namespace fractal {

using nlohmann::json;

namespace {

enum Stream : uint64_t { kYaw = 0xf4ac2, kTilt = 0xf4ac3 };

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0)
{
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

Schema<FractalRockParams> makeRockSchema()
{
    using P = FractalRockParams;
    Schema<P> s("fractal", "One fractal rock: an icosahedron refined by deterministic midpoint "
                           "displacement and subdivision damping.");
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
    s.add(param("seed", ParamType::Int, "", 0, Range::atLeast(0),
                "Random seed: displacements and orientation (same seed, same bits)"),
          [](const P& p) { return json(p.shape.seed); },
          [](P& p, const json& j) { p.shape.seed = j.get<uint64_t>(); });
    s.member(param("voxel-size", ParamType::Real, "m", 0.01, Range::closed(1e-6, 1e6),
                   "Voxel edge length of the level set"), &P::voxelSize);
    s.member(param("half-width", ParamType::Real, "voxels", 3.0, Range::closed(1, 64),
                   "Narrow-band half width"), &P::halfWidth);
    s.member(param("normal-levels", ParamType::Int, "", 2, Range::closed(1, 4),
                   "Normal map: levels of the finer model its normals come from (§7)"),
             &P::normalLevels);
    s.member(param("normal-map-size", ParamType::Int, "pixels", 256, Range::closed(16, 4096),
                   "Normal map: pixels per cell (the image is 5n × 2n)"), &P::normalMapSize);
    s.member(param("max-memory", ParamType::Real, "GB", 0.0, Range::atLeast(0),
                   "Refuse work estimated above this (0 = 75% of RAM)"), &P::maxMemoryGB);
    s.rule([](const P& p) {
        if (!(p.shape.roughness >= 0)) fail<ValueError>("fractal: roughness must be >= 0");
    });
    return s;
}

double memoryLimit(double gb)
{
    return gb > 0 ? gb * 1e9 : 0.75 * physicalMemoryBytes();
}

// The rock's orientation: yaw uniform, then a tilt about a random horizontal axis with the
// tilted up axis uniform over the spherical cap of angle `tilt` (180°: uniform rotations).
std::array<Vec3d, 3> orientation(uint64_t seed, double tiltDeg)
{
    const double yaw = 2 * M_PI * random::uniform(seed, kYaw, 0);
    const double capCos = std::cos(tiltDeg * M_PI / 180.0);
    const double c = 1.0 - random::uniform(seed, kTilt, 0) * (1.0 - capCos); // cos of the tilt
    const double tilt = std::acos(std::min(1.0, std::max(-1.0, c)));
    const double axis = 2 * M_PI * random::uniform(seed, kTilt, 1);
    // R = T(axis, tilt) · Z(yaw), T by Rodrigues about (cos axis, sin axis, 0).
    const double cy = std::cos(yaw), sy = std::sin(yaw);
    const Vec3d z0(cy, -sy, 0), z1(sy, cy, 0), z2(0, 0, 1); // rows of Z(yaw)
    const Vec3d k(std::cos(axis), std::sin(axis), 0);
    const double ct = std::cos(tilt), st = std::sin(tilt);
    std::array<Vec3d, 3> T;
    for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) {
            const double kk = k[r] * k[q] * (1 - ct);
            double cross = 0; // [k]× entries
            if (r == 0 && q == 1) cross = -k[2];
            if (r == 0 && q == 2) cross = k[1];
            if (r == 1 && q == 0) cross = k[2];
            if (r == 1 && q == 2) cross = -k[0];
            if (r == 2 && q == 0) cross = -k[1];
            if (r == 2 && q == 1) cross = k[0];
            T[size_t(r)][q] = (r == q ? ct : 0.0) + kk + st * cross;
        }
    std::array<Vec3d, 3> R;
    const Vec3d cols[3] = {Vec3d(z0[0], z1[0], z2[0]), Vec3d(z0[1], z1[1], z2[1]), Vec3d(z0[2], z1[2], z2[2])};
    for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) R[size_t(r)][q] = T[size_t(r)].dot(cols[q]);
    return R;
}

// Object-space normal map of the finer model, laid out as UvLayout (§7).
void normalMap(const RockMesh& fine, const std::vector<Vec3d>& fineWorld, int cell,
               std::vector<float>& rgb, int& width, int& height, Task& task)
{
    const std::vector<Vec3d> normals = vertexNormals(fineWorld, fine.triangles);
    const uint32_t N = fine.lattice;
    const size_t P = size_t(N + 1) * (N + 2) / 2;
    // Vertex at lattice point (i, j) of base face f.
    std::vector<unsigned> vertexAt(20 * P, ~0u);
    for (size_t t = 0; t < fine.triangles.size(); ++t) {
        const auto& c = fine.corners[t];
        for (int q = 0; q < 3; ++q) {
            const size_t i = c[size_t(2 * q)], j = c[size_t(2 * q + 1)];
            vertexAt[size_t(fine.baseFace[t]) * P + j * (N + 1) - j * (j - 1) / 2 + i] = fine.triangles[t][q];
        }
    }
    width = 5 * cell;
    height = 2 * cell;
    rgb.assign(size_t(width) * size_t(height) * 3, 0.0f);
    const UvLayout layout;
    const double r = (2.0 - std::sqrt(2.0)) / 2.0, s = 1.0 - layout.gutter / r;
    parallelFor(task, size_t(height), 8, [&](size_t row) {
        const double v = 1.0 - (double(row) + 0.5) / height;
        for (int col = 0; col < width; ++col) {
            const double u = (col + 0.5) / width;
            const int cx = std::min(4, int(u * 5)), cy = std::min(1, int(v * 2));
            double x = u * 5 - cx, y = v * 2 - cy;
            const bool lower = x + y <= 1.0;
            const double ic = lower ? r : 1.0 - r;
            x = ic + (x - ic) / s;
            y = ic + (y - ic) / s;
            const int face = (cy * 5 + cx) * 2 + (lower ? 0 : 1);
            double a = lower ? x : 1.0 - x, b = lower ? y : 1.0 - y;
            a = std::max(0.0, a);
            b = std::max(0.0, b);
            if (a + b > 1.0) {
                const double sum = a + b;
                a /= sum;
                b /= sum;
            }
            // The fine triangle at lattice (a, b)·N and the barycentric blend of its normals.
            const double fa = a * N, fb = b * N;
            int i = std::min(int(N) - 1, int(std::floor(fa))), j = std::min(int(N) - 1, int(std::floor(fb)));
            if (i + j > int(N) - 1) {
                // On the far edge: step back into the last row of upright triangles.
                if (i > 0) --i; else --j;
            }
            const double da = fa - i, db = fb - j;
            auto at = [&](int ii, int jj) {
                return normals[vertexAt[size_t(face) * P + size_t(jj) * (N + 1) - size_t(jj) * (jj - 1) / 2 + size_t(ii)]];
            };
            Vec3d n;
            if (da + db <= 1.0 || i + j + 2 > int(N)) {
                n = at(i, j) * (1.0 - da - db) + at(i + 1, j) * da + at(i, j + 1) * db;
            } else {
                n = at(i + 1, j + 1) * (da + db - 1.0) + at(i + 1, j) * (1.0 - db) + at(i, j + 1) * (1.0 - da);
            }
            const double len = n.length();
            if (len > 0) n /= len;
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

const char* normalMapHelp()
{
    return "Normal map (§7): an RGB float EXR of the normals of a model normal-levels finer, "
           "averaged per vertex, in the mesh file's coordinates (object space, z up), stored as "
           "n/2 + 1/2. UV layout (written into the OBJ as vt): the 20 icosahedron faces in 10 "
           "square cells, 5 across and 2 down (the image is 5n x 2n pixels); face 2k and 2k+1 "
           "share cell k (column k mod 5, row k div 5 from the bottom): 2k its lower-left "
           "half, 2k+1 its upper-right half, each shrunk by a 1% gutter.";
}

RockResult runRock(const FractalRockParams& p, bool withLevelSet, bool withNormalMap, Task& task)
{
    rockSchema().validate(p);
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
        const double a = extent[0], b = extent[1], c = extent[2];
        const double area = 4 * M_PI * std::pow((std::pow(a * b, 1.6) + std::pow(a * c, 1.6) + std::pow(b * c, 1.6)) / 3, 1 / 1.6);
        const double voxels = 2.0 * area / (dx * dx) * 2.0 * p.halfWidth;
        if (voxels * 40 > limit) {
            fail<ValueError>("fractal: a ", p.size[0], " m rock at ", dx, " m voxels needs about ",
                             formatBytes(voxels * 40), " (over the ", formatBytes(limit),
                             " limit); use a larger --voxel-size or raise --max-memory");
        }
    }
    RockResult r;
    const std::array<Vec3d, 3> R = orientation(p.shape.seed, p.tilt);
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
        normalMap(fine, toWorld(fine, extent, R, p.center), p.normalMapSize, r.normalMap,
                  r.normalMapWidth, r.normalMapHeight, task);
        r.stats.normalMapSeconds = since(t0);
    }
    if (withLevelSet) {
        task.phase("level set", withNormalMap ? 0.4 : 0.7);
        t0 = Clock::now();
        auto xf = openvdb::math::Transform::createLinearTransform(dx);
        // meshToVolume reads index-space points.
        std::vector<openvdb::Vec3s> index(r.mesh.points.size());
        tbb::parallel_for(size_t(0), index.size(), [&](size_t i) {
            index[i] = openvdb::Vec3s(xf->worldToIndex(world[i]));
        });
        openvdb::tools::QuadAndTriangleDataAdapter<openvdb::Vec3s, openvdb::Vec3I> adapter(
            index, r.mesh.triangles);
        const float hw = float(p.halfWidth);
        r.surface = openvdb::tools::meshToVolume<openvdb::FloatGrid>(*task.interrupter(), adapter, *xf, hw, hw);
        task.check();
        r.surface->setGridClass(openvdb::GRID_LEVEL_SET);
        r.surface->setName("surface");
        r.stats.levelSetSeconds = since(t0);
        r.stats.activeVoxels = size_t(r.surface->activeVoxelCount());
        stampProvenance(*r.surface, kToolName, rockSchema().toJson(p).dump());
    }
    task.done();
    return r;
}

} // namespace fractal
} // namespace rockvdb
