// SPDX-License-Identifier: Apache-2.0
// The only rockvdb file that includes CGAL (slow to compile): keep it small.
#include "Hull.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polyhedron_3.h>
#include <CGAL/convex_hull_3.h>

#include <algorithm>
#include <map>
#include <tuple>
#include <cmath>

namespace rockvdb {
namespace blocks {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Polyhedron = CGAL::Polyhedron_3<K>;

// Affine dimension: farthest point from p0, then from the line, then from the plane.
int affineDimension(const std::vector<Vec3d>& pts, double tol)
{
    if (pts.empty()) return -1;
    const Vec3d p0 = pts[0];
    size_t i1 = 0;
    double best = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
        const double d = (pts[i] - p0).length();
        if (d > best) { best = d; i1 = i; }
    }
    if (best <= tol) return 0;
    const Vec3d u = (pts[i1] - p0).unit();
    size_t i2 = 0;
    best = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
        const Vec3d w = pts[i] - p0;
        const double d = (w - u * w.dot(u)).length();
        if (d > best) { best = d; i2 = i; }
    }
    if (best <= tol) return 1;
    const Vec3d n = u.cross(pts[i2] - p0).unit();
    best = 0;
    for (const auto& p : pts) best = std::max(best, std::abs((p - p0).dot(n)));
    return best <= tol ? 2 : 3;
}

} // namespace

Hull convexHull(const std::vector<Vec3d>& points, double tolerance)
{
    Hull h;
    h.dimension = affineDimension(points, tolerance);
    if (h.dimension < 3) return h;

    std::vector<Point> pts;
    pts.reserve(points.size());
    Vec3d centroid(0);
    for (const auto& p : points) {
        pts.emplace_back(p[0], p[1], p[2]);
        centroid += p;
    }
    centroid /= double(points.size());
    Polyhedron poly;
    CGAL::convex_hull_3(pts.begin(), pts.end(), poly);

    std::map<const Polyhedron::Vertex*, uint32_t> vertexIndex;
    for (auto v = poly.vertices_begin(); v != poly.vertices_end(); ++v) {
        const Point& p = v->point();
        vertexIndex[&*v] = uint32_t(h.vertices.size());
        h.vertices.emplace_back(p.x(), p.y(), p.z());
    }
    // Triangular facets → planes; coplanar neighbours (same normal and offset) merge.
    for (auto f = poly.facets_begin(); f != poly.facets_end(); ++f) {
        auto he = f->facet_begin();
        const auto va = he->vertex();
        const Point& pa = va->point();
        ++he;
        const auto vb = he->vertex();
        const Point& pb = vb->point();
        ++he;
        const auto vc = he->vertex();
        const Point& pc = vc->point();
        // convex_hull_3's facets run counter-clockwise seen from outside
        h.triangles.push_back({vertexIndex[&*va], vertexIndex[&*vb], vertexIndex[&*vc]});
        const Vec3d a(pa.x(), pa.y(), pa.z()), b(pb.x(), pb.y(), pb.z()), c(pc.x(), pc.y(), pc.z());
        Vec3d n = (b - a).cross(c - a);
        const double len = n.length();
        if (len <= 0) continue;
        const double area = 0.5 * len;
        n /= len;
        double d = n.dot(a);
        if (n.dot(centroid) > d) { n = -n; d = -d; } // outward
        bool merged = false;
        for (size_t k = 0; k < h.planes.size(); ++k) {
            const auto& q = h.planes[k];
            if (std::abs(q[0] - n[0]) < 1e-7 && std::abs(q[1] - n[1]) < 1e-7 &&
                std::abs(q[2] - n[2]) < 1e-7 && std::abs(q[3] - d) < tolerance) {
                h.areas[k] += area;
                merged = true;
                break;
            }
        }
        if (!merged) {
            h.planes.push_back({n[0], n[1], n[2], d});
            h.areas.push_back(area);
        }
    }
    // CGAL hands the hull's vertices and facets over in an order that follows memory addresses
    // (handles in hashed maps), so it changes from run to run: vertices sorted by position,
    // each triangle from its lowest index on (orientation kept), triangles sorted, make the
    // mesh a function of the points alone.
    std::vector<uint32_t> order(h.vertices.size());
    for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
        const Vec3d &p = h.vertices[a], &q = h.vertices[b];
        return std::make_tuple(p[0], p[1], p[2]) < std::make_tuple(q[0], q[1], q[2]);
    });
    std::vector<uint32_t> rank(order.size());
    std::vector<Vec3d> sorted(order.size());
    for (uint32_t i = 0; i < order.size(); ++i) {
        rank[order[i]] = i;
        sorted[i] = h.vertices[order[i]];
    }
    h.vertices.swap(sorted);
    for (auto& t : h.triangles) {
        for (auto& v : t) v = rank[v];
        std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    }
    std::sort(h.triangles.begin(), h.triangles.end());
    return h;
}

} // namespace blocks
} // namespace rockvdb
