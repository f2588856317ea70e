// SPDX-License-Identifier: Apache-2.0
#include "Atlas.h"

#include <rockvdb/core/Error.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cmath>
#include <map>
#include <numeric>
#include <utility>

namespace rockvdb {
namespace asset {

namespace {

// The projection of axis a (0..5: +x, -x, +y, -y, +z, -z) seen from outside: (u, v) with u
// right and v up, so a chart keeps the triangles' counter-clockwise winding.
openvdb::Vec2d project(int a, const openvdb::Vec3d& p)
{
    switch (a) {
    case 0: return {p.y(), p.z()};   // +x: looking down -x, y right, z up
    case 1: return {-p.y(), p.z()};  // -x
    case 2: return {-p.x(), p.z()};  // +y
    case 3: return {p.x(), p.z()};   // -y
    case 4: return {p.x(), p.y()};   // +z: looking down, x right, y up
    default: return {-p.x(), p.y()}; // -z
    }
}

double cross(const openvdb::Vec2d& a, const openvdb::Vec2d& b)
{
    return a.x() * b.y() - a.y() * b.x();
}

// Whether two counter-clockwise triangles' interiors meet: no edge of either separates them
// (the separating axis theorem; touching along an edge or at a corner is not meeting).
bool overlap(const std::array<openvdb::Vec2d, 3>& a, const std::array<openvdb::Vec2d, 3>& b)
{
    auto separates = [](const std::array<openvdb::Vec2d, 3>& p, const std::array<openvdb::Vec2d, 3>& q) {
        const double scale = std::max((p[1] - p[0]).lengthSqr(), (p[2] - p[0]).lengthSqr());
        for (int k = 0; k < 3; ++k) {
            const openvdb::Vec2d e = p[(k + 1) % 3] - p[k];
            bool allOutside = true;
            for (int m = 0; m < 3 && allOutside; ++m) {
                allOutside = cross(e, q[m] - p[k]) <= 1e-12 * scale; // on or right of the edge
            }
            if (allOutside) return true;
        }
        return false;
    };
    return !separates(a, b) && !separates(b, a);
}

int axisOf(const openvdb::Vec3d& n)
{
    int k = 0;
    for (int i = 1; i < 3; ++i) {
        if (std::abs(n[i]) > std::abs(n[k])) k = i;
    }
    return 2 * k + (n[k] < 0 ? 1 : 0);
}

struct Chart
{
    std::vector<uint32_t> triangles;
    openvdb::Vec2d lo{1e300, 1e300}, hi{-1e300, -1e300}; // projected bounds (m)
    openvdb::Vec2d at;                                  // packed corner (texels)
};

} // namespace

UvMesh atlas(const TriMesh& mesh, int textureSize, int padding)
{
    require(textureSize >= 8 && textureSize <= 16384, "asset", "texture-size", "in [8, 16384]",
            textureSize);
    require(padding >= 0 && padding <= textureSize / 8, "asset", "padding",
            "in [0, texture-size / 8]", padding);
    const size_t nt = mesh.triangles();
    if (nt == 0) fail<ValueError>("asset: the mesh has no triangles");

    // Axis per triangle, then charts: connected (by shared edges) triangles of one axis.
    std::vector<int> axis(nt);
    for (size_t t = 0; t < nt; ++t) {
        const openvdb::Vec3d a = mesh.points[mesh.indices[3 * t]];
        const openvdb::Vec3d b = mesh.points[mesh.indices[3 * t + 1]];
        const openvdb::Vec3d c = mesh.points[mesh.indices[3 * t + 2]];
        axis[t] = axisOf((b - a).cross(c - a));
    }
    // Charts grow breadth first over shared edges among triangles of one axis, in triangle
    // order; a triangle whose projection would overlap one already in the chart (a fold: a
    // simplified mesh can pleat where its faces stay within 55 degrees of the axis) waits
    // for a chart of its own. A grid of the chart's projected triangles finds the candidates.
    std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> edgeTriangles;
    for (size_t t = 0; t < nt; ++t) {
        for (int k = 0; k < 3; ++k) {
            uint32_t i = mesh.indices[3 * t + k], j = mesh.indices[3 * t + (k + 1) % 3];
            if (i > j) std::swap(i, j);
            edgeTriangles[{i, j}].push_back(uint32_t(t));
        }
    }
    std::vector<std::array<openvdb::Vec2d, 3>> proj(nt);
    double edgeSum = 0;
    for (size_t t = 0; t < nt; ++t) {
        for (int k = 0; k < 3; ++k) proj[t][k] = project(axis[t], mesh.points[mesh.indices[3 * t + k]]);
        edgeSum += (proj[t][1] - proj[t][0]).length();
    }
    const double cell = std::max(edgeSum / double(nt), 1e-12);
    std::vector<Chart> charts;
    std::vector<uint32_t> chartOf(nt, UINT32_MAX);
    std::map<std::pair<int64_t, int64_t>, std::vector<uint32_t>> grid; // the current chart's
    auto cellsOf = [&](uint32_t t, auto&& visit) {
        const auto& p = proj[t];
        const int64_t x0 = int64_t(std::floor(std::min({p[0].x(), p[1].x(), p[2].x()}) / cell));
        const int64_t x1 = int64_t(std::floor(std::max({p[0].x(), p[1].x(), p[2].x()}) / cell));
        const int64_t y0 = int64_t(std::floor(std::min({p[0].y(), p[1].y(), p[2].y()}) / cell));
        const int64_t y1 = int64_t(std::floor(std::max({p[0].y(), p[1].y(), p[2].y()}) / cell));
        for (int64_t y = y0; y <= y1; ++y)
            for (int64_t x = x0; x <= x1; ++x) visit(std::make_pair(x, y));
    };
    auto overlapsChart = [&](uint32_t t) {
        bool hit = false;
        cellsOf(t, [&](const auto& c) {
            const auto it = grid.find(c);
            if (hit || it == grid.end()) return;
            for (uint32_t o : it->second) {
                if (overlap(proj[t], proj[o])) {
                    hit = true;
                    return;
                }
            }
        });
        return hit;
    };
    for (size_t seed = 0; seed < nt; ++seed) {
        if (chartOf[seed] != UINT32_MAX) continue;
        const uint32_t id = uint32_t(charts.size());
        charts.emplace_back();
        grid.clear();
        std::vector<uint32_t> queue{uint32_t(seed)};
        chartOf[seed] = id;
        for (size_t head = 0; head < queue.size(); ++head) {
            const uint32_t t = queue[head];
            Chart& ch = charts[id];
            ch.triangles.push_back(t);
            cellsOf(t, [&](const auto& c) { grid[c].push_back(t); });
            for (int k = 0; k < 3; ++k) {
                ch.lo = openvdb::Vec2d(std::min(ch.lo.x(), proj[t][k].x()), std::min(ch.lo.y(), proj[t][k].y()));
                ch.hi = openvdb::Vec2d(std::max(ch.hi.x(), proj[t][k].x()), std::max(ch.hi.y(), proj[t][k].y()));
                uint32_t i = mesh.indices[3 * t + k], j = mesh.indices[3 * t + (k + 1) % 3];
                if (i > j) std::swap(i, j);
                for (uint32_t n : edgeTriangles[{i, j}]) {
                    if (chartOf[n] != UINT32_MAX || axis[n] != axis[t] || overlapsChart(n)) continue;
                    chartOf[n] = id;
                    cellsOf(n, [&](const auto& c) { grid[c].push_back(n); }); // claimed now
                    queue.push_back(n);
                }
            }
        }
        // (each triangle was entered in the grid when claimed and again when visited: the
        // duplicates only cost a second test)
    }

    // Shelf packing, tallest first, at a density (texels per metre) lowered until it fits.
    std::vector<uint32_t> order(charts.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
        return charts[a].hi.y() - charts[a].lo.y() > charts[b].hi.y() - charts[b].lo.y();
    });
    double area = 0;
    for (const Chart& ch : charts) area += (ch.hi.x() - ch.lo.x()) * (ch.hi.y() - ch.lo.y());
    const double size = textureSize, pad = padding;
    double density = 0.8 * size / std::sqrt(std::max(area, 1e-30));
    for (int attempt = 0;; ++attempt) {
        if (attempt == 400) fail<ValueError>("asset: cannot pack ", charts.size(), " charts into a ", textureSize,
                                             " texture with ", padding, " texels of padding: raise texture-size");
        double x = pad, y = pad, shelf = 0;
        bool fits = true;
        for (uint32_t c : order) {
            Chart& ch = charts[c];
            // whole texels per chart: the padding between charts stays whole texels too
            const double w = std::ceil((ch.hi.x() - ch.lo.x()) * density) + 1;
            const double h = std::ceil((ch.hi.y() - ch.lo.y()) * density) + 1;
            if (x + w + pad > size) {
                x = pad;
                y += shelf + pad;
                shelf = 0;
            }
            if (x + w + pad > size || y + h + pad > size) {
                fits = false;
                break;
            }
            ch.at = openvdb::Vec2d(x, y);
            x += w + pad;
            shelf = std::max(shelf, h);
        }
        if (fits) break;
        density *= 0.97;
    }

    UvMesh out;
    out.charts = charts.size();
    out.texelsPerMetre = density;
    out.chartOf = chartOf;
    out.indices.resize(mesh.indices.size());
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> vertexOf; // (input vertex, chart) -> vertex
    for (size_t t = 0; t < nt; ++t) {
        const Chart& ch = charts[chartOf[t]];
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = mesh.indices[3 * t + k];
            const auto [it, fresh] = vertexOf.emplace(std::make_pair(v, chartOf[t]), uint32_t(out.points.size()));
            if (fresh) {
                const openvdb::Vec2d q = project(axis[t], mesh.points[v]);
                // half a texel in from the chart's texel box on each side
                const openvdb::Vec2d texel = ch.at + (q - ch.lo) * density + openvdb::Vec2d(0.5);
                out.points.push_back(mesh.points[v]);
                out.uvs.emplace_back(float(texel.x() / size), float(texel.y() / size));
                out.source.push_back(v);
            }
            out.indices[3 * t + k] = it->second;
        }
    }
    return out;
}

} // namespace asset
} // namespace rockvdb
