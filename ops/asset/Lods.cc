// SPDX-License-Identifier: Apache-2.0
#include "Lods.h"

#include <rockvdb/core/Error.h>

#include <meshoptimizer.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <tbb/parallel_reduce.h> // parallel_deterministic_reduce: the same sums at any thread count
#include <tbb/blocked_range.h>

#include <algorithm>
#include <limits>
#include <memory>
#include <mutex>
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
    // The levels side by side: each is simplified from the full mesh alone (meshoptimizer is
    // serial inside and keeps no state), so the order they finish in does not matter.
    std::vector<Lod> lods(targets.size());
    const float* positions = full.points[0].asPointer();
    parallelFor(task, targets.size(), 1, [&](size_t i) {
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
    });
    return lods;
}

namespace {

// Distance from p to triangle (a, b, c): the closest point by its Voronoi region (Ericson,
// Real-Time Collision Detection §5.1.5).
double pointTriangle(const openvdb::Vec3d& p, const openvdb::Vec3d& a, const openvdb::Vec3d& b,
                     const openvdb::Vec3d& c)
{
    const openvdb::Vec3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) return ap.length();
    const openvdb::Vec3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) return bp.length();
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + ab * (d1 / (d1 - d3)))).length();
    const openvdb::Vec3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) return cp.length();
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + ac * (d2 / (d2 - d6)))).length();
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).length();
    }
    const double denom = 1.0 / (va + vb + vc);
    return (p - (a + ab * (vb * denom) + ac * (vc * denom))).length();
}

} // namespace

TriangleDistance::TriangleDistance(const TriMesh& mesh) : mMesh(mesh)
{
    const size_t nt = mesh.triangles();
    if (nt == 0) fail<ValueError>("asset: a distance to a mesh without triangles");
    openvdb::BBoxd box;
    double edges = 0;
    for (size_t t = 0; t < nt; ++t) {
        const openvdb::Vec3d a = mesh.points[mesh.indices[3 * t]], b = mesh.points[mesh.indices[3 * t + 1]],
                             c = mesh.points[mesh.indices[3 * t + 2]];
        box.expand(a), box.expand(b), box.expand(c);
        edges += (b - a).length() + (c - b).length() + (a - c).length();
    }
    const openvdb::Vec3d ext = box.extents();
    // Cells about twice the mean edge, at most ~2^21 of them.
    mCell = std::max({2.0 * edges / double(3 * nt), ext[box.maxExtent()] / 128.0, 1e-9});
    mOrigin = box.min();
    for (int k = 0; k < 3; ++k) mDims[k] = std::max(1, int(std::floor(ext[k] / mCell)) + 1);
    const size_t cells = size_t(mDims[0]) * size_t(mDims[1]) * size_t(mDims[2]);
    auto cellRange = [&](size_t t, openvdb::Coord& lo, openvdb::Coord& hi) {
        openvdb::BBoxd tb;
        for (int k = 0; k < 3; ++k) tb.expand(openvdb::Vec3d(mesh.points[mesh.indices[3 * t + k]]));
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::clamp(int(std::floor((tb.min()[k] - mOrigin[k]) / mCell)), 0, mDims[k] - 1);
            hi[k] = std::clamp(int(std::floor((tb.max()[k] - mOrigin[k]) / mCell)), 0, mDims[k] - 1);
        }
    };
    auto index = [&](int x, int y, int z) { return (size_t(x) * size_t(mDims[1]) + size_t(y)) * size_t(mDims[2]) + size_t(z); };
    // Counting sort of (cell, triangle) pairs: triangles in rising order within each cell.
    mStart.assign(cells + 1, 0);
    openvdb::Coord lo, hi;
    for (size_t t = 0; t < nt; ++t) {
        cellRange(t, lo, hi);
        for (int x = lo[0]; x <= hi[0]; ++x)
            for (int y = lo[1]; y <= hi[1]; ++y)
                for (int z = lo[2]; z <= hi[2]; ++z) ++mStart[index(x, y, z) + 1];
    }
    for (size_t c = 0; c < cells; ++c) mStart[c + 1] += mStart[c];
    mItems.resize(mStart[cells]);
    std::vector<uint32_t> fill(mStart.begin(), mStart.end() - 1);
    for (size_t t = 0; t < nt; ++t) {
        cellRange(t, lo, hi);
        for (int x = lo[0]; x <= hi[0]; ++x)
            for (int y = lo[1]; y <= hi[1]; ++y)
                for (int z = lo[2]; z <= hi[2]; ++z) mItems[fill[index(x, y, z)]++] = uint32_t(t);
    }
}

double TriangleDistance::to(const openvdb::Vec3d& p, uint32_t t) const
{
    return pointTriangle(p, mMesh.points[mMesh.indices[3 * t]], mMesh.points[mMesh.indices[3 * t + 1]],
                         mMesh.points[mMesh.indices[3 * t + 2]]);
}

double TriangleDistance::operator()(const openvdb::Vec3d& p, uint32_t* nearest) const
{
    // The query's cell (clamped into the grid) and its distance outside the grid's box.
    openvdb::Coord c;
    double outside2 = 0;
    for (int k = 0; k < 3; ++k) {
        const double u = (p[k] - mOrigin[k]) / mCell;
        c[k] = std::clamp(int(std::floor(u)), 0, mDims[k] - 1);
        const double below = mOrigin[k] - p[k], above = p[k] - (mOrigin[k] + mDims[k] * mCell);
        const double d = std::max({below, above, 0.0});
        outside2 += d * d;
    }
    double best = std::numeric_limits<double>::max();
    const int maxRing = std::max({mDims[0], mDims[1], mDims[2]});
    for (int r = 0; r <= maxRing; ++r) {
        // Every triangle not yet seen lies in cells r or more shells out: at least r - 1
        // cells away
        // (outside the grid's box: the gap to the box and the shells' depth add as squares,
        // the box being convex).
        const double depth = double(std::max(r - 1, 0)) * mCell;
        if (r > 0 && best * best <= outside2 + depth * depth) break;
        for (int x = c[0] - r; x <= c[0] + r; ++x) {
            if (x < 0 || x >= mDims[0]) continue;
            for (int y = c[1] - r; y <= c[1] + r; ++y) {
                if (y < 0 || y >= mDims[1]) continue;
                const bool edgeXY = std::abs(x - c[0]) == r || std::abs(y - c[1]) == r;
                for (int z = c[2] - r; z <= c[2] + r; z += (edgeXY ? 1 : std::max(1, 2 * r))) {
                    if (z < 0 || z >= mDims[2]) continue;
                    const size_t cell = (size_t(x) * size_t(mDims[1]) + size_t(y)) * size_t(mDims[2]) + size_t(z);
                    for (uint32_t i = mStart[cell]; i < mStart[cell + 1]; ++i) {
                        const uint32_t t = mItems[i];
                        const double d = to(p, t);
                        // (ties: the lowest triangle, so the hint does not depend on the order)
                        if (d < best || (d == best && nearest && t < *nearest)) {
                            best = d;
                            if (nearest) *nearest = t;
                        }
                    }
                }
            }
        }
    }
    return best;
}

SurfaceError surfaceError(const TriMesh& mesh, const TriMesh& full, const openvdb::FloatGrid& grid)
{
    struct Sum
    {
        double total = 0, max = 0;
        size_t count = 0;
    };
    const openvdb::math::Transform& xf = grid.transform();
    // |phi| saturates at the background: such points are measured against the full mesh.
    const double saturated = 0.99 * double(grid.background());
    std::unique_ptr<TriangleDistance> toFull;
    std::once_flag built;
    auto fullDistance = [&](const openvdb::Vec3d& p) {
        std::call_once(built, [&] { toFull = std::make_unique<TriangleDistance>(full); });
        return (*toFull)(p);
    };
    const size_t nt = mesh.triangles();
    const Sum s = tbb::parallel_deterministic_reduce(
        tbb::blocked_range<size_t>(0, nt, 1024), Sum{},
        [&](const tbb::blocked_range<size_t>& r, Sum acc) {
            auto a = grid.getConstAccessor();
            auto at = [&](const openvdb::Vec3d& p) {
                double d = std::abs(double(openvdb::tools::BoxSampler::sample(a, xf.worldToIndex(p))));
                if (d >= saturated) d = std::max(d, fullDistance(p));
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
    // surface -> lod: every vertex of the full mesh (a max: any order gives the same). Early
    // out (Taha & Hanbury 2015): the distance to the triangle nearest the previous vertex
    // bounds this one's from above; at or below the maximum found so far, the vertex cannot
    // raise it. volumeToMesh's vertices come leaf by leaf, so neighbours follow each other.
    const TriangleDistance toLod(mesh);
    const double back = tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, full.points.size(), 4096), 0.0,
        [&](const tbb::blocked_range<size_t>& r, double m) {
            uint32_t hint = 0;
            for (size_t v = r.begin(); v < r.end(); ++v) {
                const openvdb::Vec3d p(full.points[v]);
                if (toLod.to(p, hint) <= m) continue;
                m = std::max(m, toLod(p, &hint));
            }
            return m;
        },
        [](double x, double y) { return std::max(x, y); });
    SurfaceError e;
    e.mean = s.count ? s.total / double(s.count) : 0.0;
    e.max = s.max;
    e.back = back;
    e.hausdorff = std::max(e.max, e.back);
    return e;
}

} // namespace asset
} // namespace rockvdb
