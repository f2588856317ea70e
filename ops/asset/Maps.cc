// SPDX-License-Identifier: Apache-2.0
#include "Maps.h"

#include <rockvdb/asset/Cut.h>
#include <rockvdb/core/Error.h>

#include <openvdb/tools/GridOperators.h>
#include <openvdb/tools/Interpolation.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>

namespace rockvdb {
namespace asset {

namespace {

openvdb::Vec3d safeUnit(const openvdb::Vec3d& v, const openvdb::Vec3d& fallback)
{
    const double l = v.length();
    return l > 1e-20 ? v / l : fallback;
}

// The tangent frame at barycentric (b0, b1, b2) of triangle t, as an engine interpolates it.
void frameAt(const UvMesh& m, const VertexFrames& f, size_t t, const openvdb::Vec3d& b,
             openvdb::Vec3d& n, openvdb::Vec3d& tan, openvdb::Vec3d& bit)
{
    openvdb::Vec3d ni(0), ti(0);
    double w = 0;
    for (int k = 0; k < 3; ++k) {
        const uint32_t v = m.indices[3 * t + k];
        ni += b[k] * openvdb::Vec3d(f.normals[v]);
        const openvdb::Vec4f& tv = f.tangents[v];
        ti += b[k] * openvdb::Vec3d(tv[0], tv[1], tv[2]);
        w += b[k] * tv[3];
    }
    n = safeUnit(ni, openvdb::Vec3d(0, 0, 1));
    tan = safeUnit(ti - n * n.dot(ti), openvdb::Vec3d(1, 0, 0));
    bit = n.cross(tan) * (w < 0 ? -1.0 : 1.0);
}

// The level set's distance and gradient at world points (trilinear samples of the level set
// and of its gradient grid), and a point's projection onto the zero set: two Newton steps
// q = p - phi(p) grad phi / |grad phi|². Unregistered accessors: registering one per
// triangle would serialise on the tree's accessor registry.
class SdfProbe
{
public:
    explicit SdfProbe(const SurfaceField& f)
        : mAcc(f.grid.tree()), mGrad(f.gradient->tree()), mXf(f.grid.transform()) {}

    double phi(const openvdb::Vec3d& p)
    {
        return double(openvdb::tools::BoxSampler::sample(mAcc, mXf.worldToIndex(p)));
    }
    openvdb::Vec3d grad(const openvdb::Vec3d& p)
    {
        return openvdb::Vec3d(openvdb::tools::BoxSampler::sample(mGrad, mXf.worldToIndex(p)));
    }
    openvdb::Vec3d project(openvdb::Vec3d q)
    {
        for (int step = 0; step < 2; ++step) {
            const openvdb::Vec3d g = grad(q);
            const double gl = g.lengthSqr();
            if (gl < 1e-12) break;
            q -= phi(q) * g / gl;
        }
        return q;
    }

private:
    openvdb::tree::ValueAccessor<const openvdb::FloatTree, false> mAcc;
    openvdb::tree::ValueAccessor<const openvdb::Vec3STree, false> mGrad;
    const openvdb::math::Transform& mXf;
};

// The id at index point u: the nearest voxel's, else the nearest (then lowest in x, y, z
// order) of the 27 round it that holds an integer id >= 0; -1 when none does.
template<typename Acc>
int32_t maskId(Acc& acc, const openvdb::Vec3d& u)
{
    const openvdb::Coord c(int(std::floor(u.x() + 0.5)), int(std::floor(u.y() + 0.5)), int(std::floor(u.z() + 0.5)));
    auto id = [&](const openvdb::Coord& v) {
        int i;
        return asId(acc.getValue(v), i) ? int32_t(i) : int32_t(-1);
    };
    int32_t best = id(c);
    if (best >= 0) return best;
    double bestD = 1e300;
    for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dz = -1; dz <= 1; ++dz) {
                const openvdb::Coord v = c.offsetBy(dx, dy, dz);
                const int32_t i = id(v);
                const double d = (v.asVec3d() - u).lengthSqr();
                if (i >= 0 && d < bestD) best = i, bestD = d;
            }
    return best;
}

// A texture's bilinear value at uv in [0, 1]² (texel centres at (i + 1/2) / size, clamped at
// the border), as a GPU reads it without mipmaps.
openvdb::Vec3d bilinear(const std::vector<openvdb::Vec3f>& tex, int size, const openvdb::Vec2d& uv)
{
    const double x = std::clamp(uv.x() * size - 0.5, 0.0, size - 1.0);
    const double y = std::clamp(uv.y() * size - 0.5, 0.0, size - 1.0);
    const int x0 = std::min(int(x), size - 2), y0 = std::min(int(y), size - 2);
    const double fx = x - x0, fy = y - y0;
    auto at = [&](int i, int j) { return openvdb::Vec3d(tex[size_t(j) * size + i]); };
    return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
           fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

double degreesBetween(const openvdb::Vec3d& a, const openvdb::Vec3d& b)
{
    return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / M_PI;
}

} // namespace

VertexFrames vertexFrames(const UvMesh& m)
{
    const size_t nv = m.points.size(), nt = m.triangles();
    size_t sources = 0;
    for (uint32_t s : m.source) sources = std::max<size_t>(sources, s + 1);
    std::vector<openvdb::Vec3d> bySource(sources, openvdb::Vec3d(0));
    std::vector<openvdb::Vec3d> tan(nv, openvdb::Vec3d(0)), bit(nv, openvdb::Vec3d(0));
    for (size_t t = 0; t < nt; ++t) {
        const uint32_t i0 = m.indices[3 * t], i1 = m.indices[3 * t + 1], i2 = m.indices[3 * t + 2];
        const openvdb::Vec3d p0 = m.points[i0], e1 = openvdb::Vec3d(m.points[i1]) - p0,
                             e2 = openvdb::Vec3d(m.points[i2]) - p0;
        const openvdb::Vec3d fn = e1.cross(e2); // length: twice the area (area weighting)
        const openvdb::Vec2d u1 = openvdb::Vec2d(m.uvs[i1]) - openvdb::Vec2d(m.uvs[i0]);
        const openvdb::Vec2d u2 = openvdb::Vec2d(m.uvs[i2]) - openvdb::Vec2d(m.uvs[i0]);
        const double det = u1.x() * u2.y() - u2.x() * u1.y();
        openvdb::Vec3d dpdu(0), dpdv(0);
        if (std::abs(det) > 1e-30) {
            dpdu = (e1 * u2.y() - e2 * u1.y()) / det;
            dpdv = (e2 * u1.x() - e1 * u2.x()) / det;
        }
        const double area = 0.5 * fn.length();
        for (uint32_t v : {i0, i1, i2}) {
            bySource[m.source[v]] += fn;
            tan[v] += area * safeUnit(dpdu, openvdb::Vec3d(0));
            bit[v] += area * safeUnit(dpdv, openvdb::Vec3d(0));
        }
    }
    VertexFrames f;
    f.normals.resize(nv);
    f.tangents.resize(nv);
    for (size_t v = 0; v < nv; ++v) {
        const openvdb::Vec3d n = safeUnit(bySource[m.source[v]], openvdb::Vec3d(0, 0, 1));
        // any unit vector orthogonal to n when the chart gives none
        const openvdb::Vec3d any = std::abs(n.x()) < 0.9 ? openvdb::Vec3d(1, 0, 0) : openvdb::Vec3d(0, 1, 0);
        const openvdb::Vec3d t = safeUnit(tan[v] - n * n.dot(tan[v]), safeUnit(any - n * n.dot(any), any));
        const double hand = n.cross(t).dot(bit[v]) < 0 ? -1.0 : 1.0;
        f.normals[v] = openvdb::Vec3f(n);
        f.tangents[v] = openvdb::Vec4f(float(t.x()), float(t.y()), float(t.z()), float(hand));
    }
    return f;
}

openvdb::Vec3d decodeNormal(const openvdb::Vec3f& rgb, const openvdb::Vec3d& normal,
                            const openvdb::Vec4d& tangent)
{
    const openvdb::Vec3d n = safeUnit(normal, openvdb::Vec3d(0, 0, 1));
    const openvdb::Vec3d t0(tangent[0], tangent[1], tangent[2]);
    const openvdb::Vec3d t = safeUnit(t0 - n * n.dot(t0), openvdb::Vec3d(1, 0, 0));
    const openvdb::Vec3d b = n.cross(t) * (tangent[3] < 0 ? -1.0 : 1.0);
    const openvdb::Vec3d c = 2.0 * openvdb::Vec3d(rgb) - openvdb::Vec3d(1.0);
    return safeUnit(c.x() * t + c.y() * b + c.z() * n, n);
}

SurfaceField::SurfaceField(const openvdb::FloatGrid& g, const openvdb::FloatGrid* m) : grid(g), mask(m)
{
    if (grid.getGridClass() != openvdb::GRID_LEVEL_SET) {
        fail<ValueError>("asset: grid '", grid.getName(), "' is not a level set");
    }
    if (mask && mask->transform() != grid.transform()) {
        fail<ValueError>("asset: the mask grid '", mask->getName(), "' and the level set '", grid.getName(),
                         "' have different transforms");
    }
    // (tools::gradient's second-order central differences; transform-aware: world units)
    gradient = openvdb::tools::gradient(grid);
}

BakedMaps bakeMaps(const UvMesh& m, const VertexFrames& f, const openvdb::FloatGrid& grid,
                   int size, const Occlusion* occlusion, Task& task)
{
    return bakeMaps(m, f, SurfaceField(grid), size, occlusion, task);
}

NormalMapError normalMapError(const UvMesh& m, const VertexFrames& f, const BakedMaps& maps,
                              const openvdb::FloatGrid& grid)
{
    return normalMapError(m, f, maps, SurfaceField(grid));
}

BakedMaps bakeMaps(const UvMesh& m, const VertexFrames& f, const SurfaceField& field,
                   int size, const Occlusion* occlusion, Task& task)
{
    require(size >= 8 && size <= 16384, "asset", "texture-size", "in [8, 16384]", size);
    BakedMaps map;
    map.size = size;
    map.normal.assign(size_t(size) * size, openvdb::Vec3f(0.5f, 0.5f, 1.0f));
    if (occlusion) map.occlusion.assign(size_t(size) * size, 1.0f);
    map.covered.assign(size_t(size) * size, 0);
    if (field.mask) map.mask.assign(size_t(size) * size, -1);
    const size_t nt = m.triangles();
    // Triangles are independent and write disjoint texels (the atlas has no overlaps); a
    // texel centre on a shared edge is taken by the lower-numbered triangle (the test is
    // strict on one side), so the result does not depend on the order.
    parallelFor(task, nt, 64, [&](size_t t) {
        // unregistered accessors: registering one per triangle would serialise on the tree's
        // accessor registry
        SdfProbe sdf(field);
        std::optional<openvdb::tree::ValueAccessor<const openvdb::FloatTree, false>> oacc;
        if (occlusion) oacc.emplace(occlusion->value->tree());
        std::optional<openvdb::tree::ValueAccessor<const openvdb::FloatTree, false>> macc;
        if (field.mask) macc.emplace(field.mask->tree());
        openvdb::Vec2d uv[3];
        openvdb::Vec3d P[3];
        for (int k = 0; k < 3; ++k) {
            uv[k] = openvdb::Vec2d(m.uvs[m.indices[3 * t + k]]) * double(size);
            P[k] = m.points[m.indices[3 * t + k]];
        }
        const double area = (uv[1] - uv[0]).x() * (uv[2] - uv[0]).y() - (uv[2] - uv[0]).x() * (uv[1] - uv[0]).y();
        if (!(area > 0)) return;
        const int x0 = std::max(0, int(std::floor(std::min({uv[0].x(), uv[1].x(), uv[2].x()}))));
        const int x1 = std::min(size - 1, int(std::ceil(std::max({uv[0].x(), uv[1].x(), uv[2].x()}))));
        const int y0 = std::max(0, int(std::floor(std::min({uv[0].y(), uv[1].y(), uv[2].y()}))));
        const int y1 = std::min(size - 1, int(std::ceil(std::max({uv[0].y(), uv[1].y(), uv[2].y()}))));
        for (int y = y0; y <= y1; ++y) {
            for (int x = x0; x <= x1; ++x) {
                const openvdb::Vec2d c(x + 0.5, y + 0.5);
                openvdb::Vec3d b;
                bool inside = true;
                for (int k = 0; k < 3; ++k) {
                    const openvdb::Vec2d e = uv[(k + 2) % 3] - uv[(k + 1) % 3];
                    const openvdb::Vec2d d = c - uv[(k + 1) % 3];
                    b[k] = (e.x() * d.y() - e.y() * d.x()) / area;
                    // top-left style rule: >= on one side, > on the other, so a texel centre
                    // on a shared edge belongs to exactly one triangle
                    inside = inside && (b[k] > 0 || (b[k] == 0 && (e.y() > 0 || (e.y() == 0 && e.x() < 0))));
                }
                if (!inside) continue;
                const openvdb::Vec3d q = sdf.project(b[0] * P[0] + b[1] * P[1] + b[2] * P[2]);
                openvdb::Vec3d n, tan, bit;
                frameAt(m, f, t, b, n, tan, bit);
                const openvdb::Vec3d hi = safeUnit(sdf.grad(q), n);
                const openvdb::Vec3d ts(hi.dot(tan), hi.dot(bit), hi.dot(n));
                const size_t i = size_t(y) * size + x;
                map.normal[i] = openvdb::Vec3f(0.5 * (ts + openvdb::Vec3d(1.0)));
                if (occlusion) {
                    map.occlusion[i] = std::clamp(openvdb::tools::BoxSampler::sample(
                        *oacc, occlusion->value->transform().worldToIndex(q)), 0.0f, 1.0f);
                }
                if (macc) map.mask[i] = maskId(*macc, field.mask->transform().worldToIndex(q));
                map.covered[i] = 1;
            }
        }
    });
    // Dilation: uncovered texels take the nearest covered one's value (breadth first, four
    // neighbours, in a fixed order), so borders bleed the chart's own colours.
    std::vector<int> from(map.normal.size(), -1);
    std::deque<size_t> queue;
    for (size_t i = 0; i < map.normal.size(); ++i) {
        if (map.covered[i]) {
            from[i] = int(i);
            queue.push_back(i);
        }
    }
    while (!queue.empty()) {
        const size_t i = queue.front();
        queue.pop_front();
        const int x = int(i % size), y = int(i / size);
        const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
        for (int k = 0; k < 4; ++k) {
            if (nx[k] < 0 || ny[k] < 0 || nx[k] >= size || ny[k] >= size) continue;
            const size_t j = size_t(ny[k]) * size + nx[k];
            if (from[j] != -1) continue;
            from[j] = from[i];
            map.normal[j] = map.normal[i];
            if (occlusion) map.occlusion[j] = map.occlusion[i];
            if (!map.mask.empty()) map.mask[j] = map.mask[i];
            queue.push_back(j);
        }
    }
    return map;
}

NormalMapError normalMapError(const UvMesh& m, const VertexFrames& f, const BakedMaps& maps,
                              const SurfaceField& field)
{
    if (maps.size < 2 || maps.normal.size() != size_t(maps.size) * maps.size) {
        fail<ValueError>("asset: normalMapError needs a baked normal map");
    }
    // Four points per triangle (its centroid and the midpoints towards each corner), weighted
    // by the triangle's area: serial, so the sums do not depend on the thread count.
    static const openvdb::Vec3d kBary[4] = {{1 / 3.0, 1 / 3.0, 1 / 3.0}, {2 / 3.0, 1 / 6.0, 1 / 6.0},
                                            {1 / 6.0, 2 / 3.0, 1 / 6.0}, {1 / 6.0, 1 / 6.0, 2 / 3.0}};
    SdfProbe sdf(field);
    NormalMapError e;
    double weight = 0;
    for (size_t t = 0; t < m.triangles(); ++t) {
        openvdb::Vec3d P[3];
        openvdb::Vec2d uv[3];
        for (int k = 0; k < 3; ++k) {
            P[k] = m.points[m.indices[3 * t + k]];
            uv[k] = m.uvs[m.indices[3 * t + k]];
        }
        const double area = 0.5 * (P[1] - P[0]).cross(P[2] - P[0]).length();
        if (!(area > 0)) continue;
        for (const openvdb::Vec3d& b : kBary) {
            const openvdb::Vec3d q = sdf.project(b[0] * P[0] + b[1] * P[1] + b[2] * P[2]);
            openvdb::Vec3d n, tan, bit;
            frameAt(m, f, t, b, n, tan, bit);
            const openvdb::Vec3d hi = safeUnit(sdf.grad(q), n);
            const openvdb::Vec3d rgb = bilinear(maps.normal, maps.size, b[0] * uv[0] + b[1] * uv[1] + b[2] * uv[2]);
            const openvdb::Vec3d c = 2.0 * rgb - openvdb::Vec3d(1.0);
            const openvdb::Vec3d mapped = safeUnit(c.x() * tan + c.y() * bit + c.z() * n, n);
            const double w = area / 4;
            e.mapDegrees += w * degreesBetween(mapped, hi);
            e.meshDegrees += w * degreesBetween(n, hi);
            weight += w;
            ++e.samples;
        }
    }
    if (weight > 0) {
        e.mapDegrees /= weight;
        e.meshDegrees /= weight;
    }
    return e;
}

} // namespace asset
} // namespace rockvdb
