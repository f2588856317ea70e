#include "Lods.h"

#include <rockvdb/core/Error.h>

#include <meshoptimizer.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <tbb/parallel_reduce.h> // parallel_deterministic_reduce: the same sums at any thread count
#include <tbb/blocked_range.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace rockvdb {
namespace asset {

TriMesh surfaceMesh(const openvdb::FloatGrid& grid)
{
    if (grid.getGridClass() != openvdb::GRID_LEVEL_SET) {
        fail<ValueError>("asset: grid '", grid.getName(), "' is not a level set");
    }
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(grid, points, triangles, quads, 0.0, 0.0);
    if (triangles.empty() && quads.empty()) {
        fail<ValueError>("asset: grid '", grid.getName(), "' has no surface (no zero crossing)");
    }
    TriMesh m;
    m.points.assign(points.begin(), points.end());
    m.indices.reserve(3 * (triangles.size() + 2 * quads.size()));
    // volumeToMesh winds clockwise seen from outside a level set: each face is reversed.
    for (const auto& t : triangles) m.indices.insert(m.indices.end(), {t[2], t[1], t[0]});
    for (const auto& q : quads) {
        // Split along the shorter diagonal (a fold along the longer one would cut a corner).
        const float d02 = (points[q[0]] - points[q[2]]).lengthSqr();
        const float d13 = (points[q[1]] - points[q[3]]).lengthSqr();
        if (d02 <= d13) {
            m.indices.insert(m.indices.end(), {q[2], q[1], q[0], q[3], q[2], q[0]});
        } else {
            m.indices.insert(m.indices.end(), {q[3], q[1], q[0], q[3], q[2], q[1]});
        }
    }
    return m;
}

std::vector<Lod> makeLods(const TriMesh& full, const std::vector<size_t>& targets, Task& task)
{
    const size_t n = full.triangles();
    for (size_t i = 0; i < targets.size(); ++i) {
        if (targets[i] == 0) fail<ValueError>("asset: LOD ", i, " asks for 0 triangles");
        if (targets[i] > n) {
            fail<ValueError>("asset: LOD ", i, " asks for ", targets[i], " triangles, more than the ",
                             n, " of the full-resolution surface");
        }
        if (i > 0 && targets[i] >= targets[i - 1]) {
            fail<ValueError>("asset: LOD triangle counts must decrease (LOD ", i, ": ",
                             targets[i], " after ", targets[i - 1], ")");
        }
    }
    std::vector<Lod> lods(targets.size());
    const float* positions = full.points[0].asPointer();
    for (size_t i = 0; i < targets.size(); ++i) {
        task.check();
        Lod& lod = lods[i];
        lod.target = targets[i];
        std::vector<uint32_t> indices(full.indices.size());
        float error = 0;
        // The error bound is left open (1 = the whole extent): the triangle count decides.
        const size_t count = meshopt_simplify(indices.data(), full.indices.data(),
                                              full.indices.size(), positions, full.points.size(),
                                              sizeof(openvdb::Vec3f), 3 * targets[i], 1.0f, 0,
                                              &error);
        indices.resize(count);
        lod.simplifyError = error;
        meshopt_optimizeVertexCache(indices.data(), indices.data(), indices.size(),
                                    full.points.size());
        std::vector<openvdb::Vec3f> points(full.points.size());
        const size_t used = meshopt_optimizeVertexFetch(points.data(), indices.data(),
                                                        indices.size(), full.points.data(),
                                                        full.points.size(), sizeof(openvdb::Vec3f));
        points.resize(used);
        lod.mesh.points = std::move(points);
        lod.mesh.indices = std::move(indices);
        task.step(double(i + 1) / double(targets.size()));
    }
    return lods;
}

SurfaceError surfaceError(const TriMesh& mesh, const openvdb::FloatGrid& grid)
{
    struct Sum
    {
        double total = 0, max = 0;
        size_t count = 0;
    };
    const openvdb::math::Transform& xf = grid.transform();
    const size_t nt = mesh.triangles();
    const Sum s = tbb::parallel_deterministic_reduce(
        tbb::blocked_range<size_t>(0, nt, 1024), Sum{},
        [&](const tbb::blocked_range<size_t>& r, Sum acc) {
            auto a = grid.getConstAccessor();
            auto at = [&](const openvdb::Vec3d& p) {
                const double d = std::abs(double(openvdb::tools::BoxSampler::sample(a, xf.worldToIndex(p))));
                acc.total += d;
                acc.max = std::max(acc.max, d);
                ++acc.count;
            };
            for (size_t t = r.begin(); t < r.end(); ++t) {
                const openvdb::Vec3d p0 = mesh.points[mesh.indices[3 * t]];
                const openvdb::Vec3d p1 = mesh.points[mesh.indices[3 * t + 1]];
                const openvdb::Vec3d p2 = mesh.points[mesh.indices[3 * t + 2]];
                at(p0); // vertices are shared: counted once per triangle that holds them
                at((p0 + p1 + p2) / 3.0);
                at(0.5 * (p0 + p1));
                at(0.5 * (p1 + p2));
                at(0.5 * (p2 + p0));
            }
            return acc;
        },
        [](Sum x, const Sum& y) {
            x.total += y.total;
            x.max = std::max(x.max, y.max);
            x.count += y.count;
            return x;
        });
    return {s.count ? s.total / double(s.count) : 0.0, s.max};
}

} // namespace asset
} // namespace rockvdb
