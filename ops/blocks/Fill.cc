// SPDX-License-Identifier: Apache-2.0
// Block tiles: blocks grown to their fractures (rockvdb's fill; the paper's blocks are the
// hulls alone).
//
// The paper's blocks are the hulls of their clusters' points, so two neighbours stand about a
// point spacing apart: with its r ≈ 10 cm points the gaps are thin, with the ≈ 0.68 m points a
// 20 m tile can afford (Table 1's counts, see resolveDefaults) a hull-only tile is half empty.
// We keep the construction (hull planes, smooth intersection, warp) and move the planes to
// the fractures before smoothing; each block takes its side of a plane it shares with a
// neighbour, w/2 from it, so the gap across is w and the two never overlap:
//  1. Fractures. A neighbouring cluster (a graph edge joins them) across a disc whose plane
//     leaves every point of one on one side and every point of the other on the other side
//     shares that plane: the fracture itself.
//  2. Room. The hull planes (for the paper's point and segment primitives, their box) move
//     out by one neighbour radius, and the box of the points grown as much bounds the block
//     (the pushed faces of a sliver's hull would meet far away).
//  3. Meeting blocks. Grown blocks that still overlap (neighbours across no separating disc:
//     a rim the clusters wrap around, a visibility split; clusters reaching into one corner)
//     get a shared plane only then, so no plane cuts a corner off two blocks that do not
//     meet (the diamond voids at four-block junctions): the widest gap of the two point sets
//     over the cutting discs' and both hulls' normals (a separating axis of two disjoint
//     hulls is among them or their edge cross products) or the search of separatingPlane,
//     mid-gap; for the rare pairs whose hulls interpenetrate, the plane that leaves the
//     smallest share of each on the wrong side. Exact polytope overlap (edges clipped by the
//     other's half-spaces); rounds repeat while new planes change what meets.
// The pair's plane is computed once, from the lower block index, so the two sides mirror it
// exactly. The faces' polytope is the intersection of the half-spaces; its vertices (for the
// bounds) come from the convex hull of the dual points n/(d − n·c), c inside, which also
// drops the planes that do not touch it; facets are ordered by area as the hull's are.
// Measured on default 20 m tiles (bench `fill`): 0.88–0.93 of the tile is rock, rounding and
// warp included (the hull-only reading: 0.49–0.70).
#include <rockvdb/blocks/TileBuild.h>

#include <rockvdb/blocks/Hull.h>

#include <algorithm>
#include <cmath>

namespace rockvdb {
namespace blocks {

namespace tilegen {

namespace {

// Vertices of {x : n_k·x <= d_k} (bounded, c inside) and which planes touch it; false when
// c is not strictly inside or the polytope is unbounded.
bool polytopeOf(const std::vector<std::array<double, 4>>& planes, const Vec3d& c,
                std::vector<Vec3d>& vertices, std::vector<bool>& used)
{
    std::vector<Vec3d> dual;
    dual.reserve(planes.size());
    for (const auto& q : planes) {
        const double h = q[3] - (q[0] * c[0] + q[1] * c[1] + q[2] * c[2]);
        if (!(h > 1e-9)) return false;
        dual.emplace_back(q[0] / h, q[1] / h, q[2] / h);
    }
    const Hull hull = convexHull(dual, 1e-12);
    if (hull.dimension < 3) return false;
    vertices.clear();
    for (const auto& f : hull.planes) {
        if (!(f[3] > 1e-12)) return false; // the centre is not inside the dual hull: unbounded
        vertices.push_back(c + Vec3d(f[0], f[1], f[2]) / f[3]);
    }
    used.assign(planes.size(), false);
    for (const auto& v : hull.vertices) {
        for (size_t k = 0; k < dual.size(); ++k) {
            if (dual[k] == v) used[k] = true;
        }
    }
    return true;
}

Vec3d meanOf(const std::vector<Vec3d>& P)
{
    Vec3d c(0);
    for (const auto& p : P) c += p;
    return c / double(P.size());
}

} // namespace

// A unit n and m with n·x < m < n·y for every x in X, y in Y (m mid-gap); false if the
// search does not find one. Deterministic for given X, Y.
bool separatingPlane(const std::vector<Vec3d>& X, const std::vector<Vec3d>& Y, Vec3d& n,
                     double& m)
{
    n = meanOf(Y) - meanOf(X);
    if (n.length() < 1e-12) return false;
    n = n.unit();
    for (int it = 0; it < 96; ++it) {
        double hx = -1e300, hy = 1e300;
        size_t ix = 0, iy = 0;
        for (size_t i = 0; i < X.size(); ++i) {
            const double h = n.dot(X[i]);
            if (h > hx) { hx = h; ix = i; }
        }
        for (size_t i = 0; i < Y.size(); ++i) {
            const double h = n.dot(Y[i]);
            if (h < hy) { hy = h; iy = i; }
        }
        if (hx < hy - 1e-9) {
            m = 0.5 * (hx + hy);
            return true;
        }
        // Turn towards the violating support pair.
        const Vec3d d = Y[iy] - X[ix];
        if (d.length() < 1e-12) return false;
        n = (n + d.unit()).unit();
    }
    return false;
}

// The plane separating clusters a and b (b's points moved by offset into a's frame), as
// (outward normal from a, position) in a's frame; computed from the lower index so both
// sides get the same plane. Candidates, in order: a cutting disc whose plane separates the
// two (the fracture itself); else the widest gap along a cutting disc's normal, a hull
// face normal of either cluster (a separating axis of two disjoint convex hulls is among
// them or their edges' cross products) or the search of separatingPlane, placed mid-gap.
bool pairPlane(const ClusterSet& cs, int a, int b, const Vec3d& offset,
               const std::vector<std::pair<int, Vec3d>>& cutDiscs,
               const std::vector<Disc>& discs, bool discOnly, Vec3d& n, double& m)
{
    const bool flip = b < a;
    const int lo = flip ? b : a, hi = flip ? a : b;
    const Vec3d off = flip ? -offset : offset; // hi's frame → lo's frame
    const std::vector<std::vector<Vec3d>>& hullNormals = cs.normals;
    // Extreme projections come from the hull vertices.
    const std::vector<Vec3d>& X = cs.support[size_t(lo)];
    std::vector<Vec3d> Y = cs.support[size_t(hi)];
    for (auto& y : Y) y += off;
    bool found = false;
    for (const auto& [d, centreA] : cutDiscs) {
        const Vec3d c = flip ? centreA - offset : centreA; // in lo's frame
        const Vec3d& u = discs[size_t(d)].normal;
        double xlo = 1e300, xhi = -1e300, ylo = 1e300, yhi = -1e300;
        for (const auto& x : X) { const double h = u.dot(x - c); xlo = std::min(xlo, h); xhi = std::max(xhi, h); }
        for (const auto& y : Y) { const double h = u.dot(y - c); ylo = std::min(ylo, h); yhi = std::max(yhi, h); }
        if (xhi < -1e-9 && ylo > 1e-9) { n = u; m = u.dot(c); found = true; break; }
        if (xlo > 1e-9 && yhi < -1e-9) { n = -u; m = -u.dot(c); found = true; break; }
    }
    if (!found && discOnly) return false;
    if (!found) {
        // The widest gap over the candidate axes (either orientation).
        double bestGap = 1e-9;
        auto tryAxis = [&](Vec3d u) {
            if (u.length() < 1e-12) return;
            u = u.unit();
            for (int sgn = 0; sgn < 2; ++sgn, u = -u) {
                double hx = -1e300, hy = 1e300;
                for (const auto& x : X) hx = std::max(hx, u.dot(x));
                for (const auto& y : Y) hy = std::min(hy, u.dot(y));
                if (hy - hx > bestGap) {
                    bestGap = hy - hx;
                    n = u;
                    m = 0.5 * (hx + hy);
                    found = true;
                }
            }
        };
        for (const auto& cd : cutDiscs) tryAxis(discs[size_t(cd.first)].normal);
        for (const auto& u : hullNormals[size_t(lo)]) tryAxis(u);
        for (const auto& u : hullNormals[size_t(hi)]) tryAxis(u);
        Vec3d ps;
        double pm;
        if (separatingPlane(X, Y, ps, pm)) tryAxis(ps);
        if (!found) {
            // Not separable (a merged sliver wraps round the neighbour): the plane, over the
            // same axes, that leaves the smallest share of each cluster's points on the
            // wrong side (shares, so that a small cluster is not given away whole): counts
            // need all the points.
            const std::vector<Vec3d>& XP = cs.points[size_t(lo)];
            std::vector<Vec3d> YP = cs.points[size_t(hi)];
            for (auto& y : YP) y += off;
            double fewest = 3.0;
            auto tryMixed = [&](Vec3d u) {
                if (u.length() < 1e-12) return;
                u = u.unit();
                if (u.dot(meanOf(YP) - meanOf(XP)) < 0) u = -u;
                std::vector<std::pair<double, int>> h; // projection, +1 for X (−1 for Y)
                for (const auto& x : XP) h.emplace_back(u.dot(x), 1);
                for (const auto& y : YP) h.emplace_back(u.dot(y), -1);
                std::sort(h.begin(), h.end());
                // Threshold after the first k: wrong = Y below + X above.
                size_t xAbove = XP.size(), yBelow = 0;
                for (size_t k = 0; k + 1 < h.size(); ++k) {
                    if (h[k].second > 0) --xAbove; else ++yBelow;
                    const double wrong = double(xAbove) / XP.size() + double(yBelow) / YP.size();
                    if (wrong < fewest && h[k + 1].first > h[k].first) {
                        fewest = wrong;
                        n = u;
                        m = 0.5 * (h[k].first + h[k + 1].first);
                        found = true;
                    }
                }
            };
            for (const auto& cd : cutDiscs) tryMixed(discs[size_t(cd.first)].normal);
            for (const auto& u : hullNormals[size_t(lo)]) tryMixed(u);
            for (const auto& u : hullNormals[size_t(hi)]) tryMixed(u);
            tryMixed(meanOf(YP) - meanOf(XP));
        }
    }
    if (!found) return false;
    if (flip) {
        // Computed in b's frame with b below: n·x_b = m. In a's frame x_b = x_a − offset, so
        // the plane is n·x_a = m + n·offset, and a's outward normal is −n.
        m = -(m + n.dot(offset));
        n = -n;
    }
    return true;
}

// b becomes the polytope of @a all, its vertices, facet areas and bounds from it; unchanged
// when the polytope is unbounded or holds neither the centroid of the cluster's points P nor
// any of them (a plane of a non-separable pair may leave the centroid outside: then the
// deepest point is the centre).
bool setPolytope(Block& b, const std::vector<std::array<double, 4>>& all,
                 const std::vector<Vec3d>& P)
{
    auto depth = [&](const Vec3d& x) {
        double d = 1e300;
        for (const auto& q : all) d = std::min(d, q[3] - (q[0] * x[0] + q[1] * x[1] + q[2] * x[2]));
        return d;
    };
    Vec3d c = meanOf(P);
    if (!(depth(c) > 1e-6)) {
        double best = 1e-6;
        for (const auto& x : P) {
            const double d = depth(x);
            if (d > best) { best = d; c = x; }
        }
    }
    std::vector<Vec3d> verts;
    std::vector<bool> used;
    if (!polytopeOf(all, c, verts, used)) return false;
    // Facet areas (the polygon of the vertices on each plane), for the fold order: largest
    // facets first, as makeBlock's.
    std::vector<double> area(all.size(), 0.0);
    for (size_t k = 0; k < all.size(); ++k) {
        if (!used[k]) continue;
        const Vec3d n(all[k][0], all[k][1], all[k][2]);
        std::vector<Vec3d> on;
        for (const auto& v : verts) {
            if (std::abs(n.dot(v) - all[k][3]) < 1e-6 * (1.0 + std::abs(all[k][3]))) on.push_back(v);
        }
        if (on.size() < 3) continue;
        const Vec3d m = meanOf(on);
        Vec3d e1, e2;
        frame(n, e1, e2);
        std::sort(on.begin(), on.end(), [&](const Vec3d& x, const Vec3d& y) {
            return std::atan2((x - m).dot(e2), (x - m).dot(e1)) < std::atan2((y - m).dot(e2), (y - m).dot(e1));
        });
        for (size_t i = 0; i < on.size(); ++i) {
            area[k] += 0.5 * n.dot((on[i] - m).cross(on[(i + 1) % on.size()] - m));
        }
    }
    std::vector<size_t> order;
    for (size_t k = 0; k < all.size(); ++k) if (used[k]) order.push_back(k);
    std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) { return area[x] > area[y]; });
    Block out = b;
    out.kind = BlockKind::Polytope;
    out.planes.clear();
    out.areas.clear();
    for (size_t k : order) {
        out.planes.push_back({float(all[k][0]), float(all[k][1]), float(all[k][2]), float(all[k][3])});
        out.areas.push_back(float(area[k]));
    }
    out.vertices.clear();
    Vec3d lo = verts[0], hi = verts[0];
    for (const auto& v : verts) {
        out.vertices.push_back(f3(v));
        lo = minComponent(lo, v);
        hi = maxComponent(hi, v);
    }
    // The smooth intersection only shrinks and the tile field adds the warp's amplitude to
    // the bounds: the vertices bound the block.
    out.boundsMin = f3(lo);
    out.boundsMax = f3(hi);
    b = std::move(out);
    return true;
}

// The edges of polytope b: vertex pairs on two common planes.
std::vector<std::pair<int, int>> edgesOf(const Block& b)
{
    const size_t nv = b.vertices.size();
    std::vector<std::vector<int>> on(nv);
    for (size_t v = 0; v < nv; ++v) {
        const auto& x = b.vertices[v];
        for (size_t k = 0; k < b.planes.size(); ++k) {
            const auto& q = b.planes[k];
            if (std::abs(double(q[0]) * x[0] + double(q[1]) * x[1] + double(q[2]) * x[2] - q[3]) < 1e-4) {
                on[v].push_back(int(k));
            }
        }
    }
    std::vector<std::pair<int, int>> edges;
    for (size_t u = 0; u < nv; ++u) {
        for (size_t v = u + 1; v < nv; ++v) {
            int shared = 0;
            for (int k : on[u]) shared += std::count(on[v].begin(), on[v].end(), k) > 0;
            if (shared >= 2) edges.emplace_back(int(u), int(v));
        }
    }
    return edges;
}

// Does polytope a meet polytope b moved by @a shift, deeper than @a tol? Exact for convex
// polytopes: their intersection's vertices are vertices of one inside the other or crossings
// of one's edges with the other's faces, so clipping every edge of each by the other's
// half-spaces (Cyrus–Beck) finds any overlap.
bool meets(const Block& a, const std::vector<std::pair<int, int>>& ea, const Block& b,
           const std::vector<std::pair<int, int>>& eb, const Vec3d& shift, double tol)
{
    auto crosses = [tol](const Block& P, const Vec3d& x0, const Vec3d& x1) {
        double t0 = 0, t1 = 1;
        for (const auto& q : P.planes) {
            const Vec3d n(q[0], q[1], q[2]);
            const double h0 = n.dot(x0) - q[3] + tol, dh = n.dot(x1 - x0);
            // h0 + t·dh < 0 inside.
            if (std::abs(dh) < 1e-15) {
                if (h0 >= 0) return false;
                continue;
            }
            const double t = -h0 / dh;
            if (dh > 0) t1 = std::min(t1, t); else t0 = std::max(t0, t);
            if (t0 >= t1) return false;
        }
        return true;
    };
    auto vec = [](const std::array<float, 3>& v) { return Vec3d(v[0], v[1], v[2]); };
    for (const auto& [u, v] : ea) {
        if (crosses(b, vec(a.vertices[size_t(u)]) - shift, vec(a.vertices[size_t(v)]) - shift)) return true;
    }
    for (const auto& [u, v] : eb) {
        if (crosses(a, vec(b.vertices[size_t(u)]) + shift, vec(b.vertices[size_t(v)]) + shift)) return true;
    }
    return false;
}

void growToFractures(Block& b, int c, const ClusterSet& cs, const std::vector<Foreign>& F,
                     const std::vector<Disc>& discs, double w, double cap,
                     std::vector<Deferred>& deferred)
{
    const std::vector<Vec3d>& P = cs.points[size_t(c)];
    std::vector<std::array<double, 4>> hullPlanes;
    if (b.kind == BlockKind::Polytope) {
        for (const auto& q : b.planes) hullPlanes.push_back({q[0], q[1], q[2], q[3]});
    } else {
        // A point or a segment (the paper's primitives): its thickened box.
        for (int a = 0; a < 3; ++a) {
            const double lo = std::min(b.a[size_t(a)], b.b[size_t(a)]) - b.radius;
            const double hi = std::max(b.a[size_t(a)], b.b[size_t(a)]) + b.radius;
            std::array<double, 4> up{0, 0, 0, hi}, down{0, 0, 0, -lo};
            up[size_t(a)] = 1;
            down[size_t(a)] = -1;
            hullPlanes.push_back(up);
            hullPlanes.push_back(down);
        }
    }
    // 1. One plane per neighbouring cluster (image): group the foreign points by it.
    auto key = [&](const Foreign& f) {
        return std::make_tuple(f.cluster, std::llround(f.offset[0] / 1e-3),
                               std::llround(f.offset[1] / 1e-3), std::llround(f.offset[2] / 1e-3));
    };
    std::vector<size_t> order(F.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) { return key(F[x]) < key(F[y]); });
    std::vector<std::array<double, 4>> pairPlanes;
    std::vector<Vec3d> loose;
    for (size_t g = 0; g < order.size();) {
        size_t e = g;
        while (e < order.size() && key(F[order[e]]) == key(F[order[g]])) ++e;
        const Foreign& f = F[order[g]];
        bool found = false;
        if (f.cluster >= 0) {
            std::vector<std::pair<int, Vec3d>> cut;
            for (size_t k = g; k < e; ++k) {
                if (F[order[k]].disc >= 0) cut.emplace_back(F[order[k]].disc, F[order[k]].centre);
            }
            std::sort(cut.begin(), cut.end(), [](const auto& x, const auto& y) {
                return std::make_tuple(x.first, x.second[0], x.second[1], x.second[2]) <
                       std::make_tuple(y.first, y.second[0], y.second[1], y.second[2]);
            });
            Vec3d n;
            double m;
            if (pairPlane(cs, c, f.cluster, f.offset, cut, discs, true, n, m)) {
                pairPlanes.push_back({n[0], n[1], n[2], m - 0.5 * w});
            } else {
                deferred.push_back({f.cluster, f.offset, std::move(cut)});
            }
            found = true;
        }
        if (!found) {
            for (size_t k = g; k < e; ++k) loose.push_back(F[order[k]].q);
        }
        g = e;
    }
    // 2. Hull planes move out by the cap, or halfway to a loose foreign point in front.
    for (auto& q : hullPlanes) {
        const Vec3d n(q[0], q[1], q[2]);
        double push = cap;
        for (const auto& f : loose) {
            const double h = n.dot(f) - q[3];
            if (h > 1e-9) push = std::min(push, 0.5 * (h - w));
        }
        q[3] += std::max(0.0, push);
    }
    // Pushed out, the nearly parallel faces of a sliver's hull would meet far away: the box of
    // the points grown by the cap bounds the block too.
    {
        Vec3d lo = P[0], hi = P[0];
        for (const auto& x : P) { lo = minComponent(lo, x); hi = maxComponent(hi, x); }
        for (int a = 0; a < 3; ++a) {
            std::array<double, 4> up{0, 0, 0, hi[a] + cap}, down{0, 0, 0, -(lo[a] - cap)};
            up[size_t(a)] = 1;
            down[size_t(a)] = -1;
            hullPlanes.push_back(up);
            hullPlanes.push_back(down);
        }
    }
    // 3. The polytope of the pair and (pushed) hull planes; setPolytope orders its facets.
    std::vector<std::array<double, 4>> all;
    // One plane per direction: several neighbours across one fracture give the same plane,
    // and a doubled plane would make the smooth intersection shrink the whole face (by R/6).
    auto addPlane = [&](const std::array<double, 4>& q) {
        for (auto& o : all) {
            if (std::abs(o[0] - q[0]) < 1e-4 && std::abs(o[1] - q[1]) < 1e-4 &&
                std::abs(o[2] - q[2]) < 1e-4 && std::abs(o[3] - q[3]) < 1e-3) {
                o[3] = std::min(o[3], q[3]);
                return;
            }
        }
        all.push_back(q);
    };
    for (const auto& q : pairPlanes) addPlane(q);
    for (const auto& q : hullPlanes) addPlane(q);
    setPolytope(b, all, P);
}

} // namespace tilegen
} // namespace blocks
} // namespace rockvdb
