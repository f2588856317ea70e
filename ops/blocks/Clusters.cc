// SPDX-License-Identifier: Apache-2.0
// Block tiles: clusters of the fractured graph and their convex blocks (§4.1 visibility, §4.2 bases); authored blocks; the home frame.
#include <rockvdb/blocks/TileBuild.h>

#include <rockvdb/blocks/Hull.h>
#include <rockvdb/core/Random.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace rockvdb {
namespace blocks {

namespace tilegen {

namespace {

// Does any pair (p in A, q in B) of points on opposite sides cross the disc image? A and
// B hold (in-plane offset from the centre, signed height) per point.
struct Lifted { double u, v, h; };

bool anyCrossing(const std::vector<Lifted>& A, const std::vector<Lifted>& B, double r2)
{
    for (const Lifted& a : A) {
        for (const Lifted& b : B) {
            // Crossing point: (|h_b| a + |h_a| b) / (|h_a| + |h_b|) in the plane.
            const double wa = -b.h, wb = a.h, inv = 1.0 / (wa + wb);
            const double x = (wa * a.u + wb * b.u) * inv, y = (wa * a.v + wb * b.v) * inv;
            if (x * x + y * y < r2) return true;
        }
    }
    return false;
}

// Andrew's monotone chain in 2D (counter-clockwise), for flat clusters.
std::vector<int> hull2d(const std::vector<std::array<double, 2>>& q)
{
    std::vector<int> idx(q.size());
    std::iota(idx.begin(), idx.end(), 0);
    std::sort(idx.begin(), idx.end(), [&](int a, int b) { return q[size_t(a)] < q[size_t(b)]; });
    auto cross = [&](int o, int a, int b) {
        return (q[size_t(a)][0] - q[size_t(o)][0]) * (q[size_t(b)][1] - q[size_t(o)][1]) -
               (q[size_t(a)][1] - q[size_t(o)][1]) * (q[size_t(b)][0] - q[size_t(o)][0]);
    };
    std::vector<int> h(2 * idx.size());
    size_t k = 0;
    for (int i : idx) {
        while (k >= 2 && cross(h[k - 2], h[k - 1], i) <= 0) --k;
        h[k++] = i;
    }
    for (size_t t = idx.size() - 1, lower = k + 1; t-- > 0;) {
        const int i = idx[t];
        while (k >= lower && cross(h[k - 2], h[k - 1], i) <= 0) --k;
        h[k++] = i;
    }
    h.resize(k > 1 ? k - 1 : k);
    return h;
}

} // namespace

// Connected components of `members` using adjacency restricted to `allowed` (by label).
std::vector<std::vector<int>> components(const std::vector<int>& members,
                                         const std::vector<std::vector<Adjacent>>& adj,
                                         std::vector<int>& label, int& nextLabel)
{
    const int mine = nextLabel++;
    for (int m : members) label[size_t(m)] = mine;
    std::vector<std::vector<int>> out;
    for (int m : members) {
        if (label[size_t(m)] != mine) continue;
        std::vector<int> comp{m};
        const int lab = nextLabel++;
        label[size_t(m)] = lab;
        for (size_t h = 0; h < comp.size(); ++h) {
            for (const auto& e : adj[size_t(comp[h])]) {
                if (label[size_t(e.to)] == mine) {
                    label[size_t(e.to)] = lab;
                    comp.push_back(e.to);
                }
            }
        }
        std::sort(comp.begin(), comp.end());
        out.push_back(std::move(comp));
    }
    return out;
}

// Unwrap a cluster by breadth-first search from its first point into pos[] (indexed by
// point). Returns false when the cluster wraps around the torus (some point reached at two
// different images); then `axis` is a wrapping axis.
bool unwrap(const std::vector<int>& comp, const std::vector<Vec3d>& pts,
            const std::vector<std::vector<Adjacent>>& adj, const std::vector<int>& label,
            int lab, double size, std::vector<Vec3d>& pos, std::vector<int>& stamp, int visit,
            int& axis)
{
    pos[size_t(comp[0])] = pts[size_t(comp[0])];
    stamp[size_t(comp[0])] = visit;
    std::vector<int> queue{comp[0]};
    queue.reserve(comp.size());
    for (size_t h = 0; h < queue.size(); ++h) {
        const int a = queue[h];
        const Vec3d pa = pos[size_t(a)];
        for (const auto& e : adj[size_t(a)]) {
            if (label[size_t(e.to)] != lab) continue;
            const Vec3d pb = pa + e.step;
            if (stamp[size_t(e.to)] != visit) {
                stamp[size_t(e.to)] = visit;
                pos[size_t(e.to)] = pb;
                queue.push_back(e.to);
            } else {
                const Vec3d d = pos[size_t(e.to)] - pb;
                for (int c = 0; c < 3; ++c) {
                    if (std::abs(d[c]) > 0.5 * size) { axis = c; return false; }
                }
            }
        }
    }
    return true;
}

// The first disc image that separates two points of the cluster (visibility, §4.1), or -1.
// Only images whose plane cuts the cluster's box and whose disc meets it are examined; the
// points nearest the disc's axis on each side are paired first (a cluster spreading around
// a disc shows it there), then every pair.
int separatingDisc(const std::vector<Vec3d>& P, const std::vector<Disc>& discs, double size,
                   Vec3d& imageCentre)
{
    Vec3d lo = P[0], hi = P[0];
    for (const auto& p : P) { lo = minComponent(lo, p); hi = maxComponent(hi, p); }
    std::vector<Lifted> plus, minus, nearPlus, nearMinus;
    for (size_t d = 0; d < discs.size(); ++d) {
        const Disc& D = discs[d];
        Vec3d ext, e1, e2;
        for (int a = 0; a < 3; ++a) ext[a] = D.radius * std::sqrt(std::max(0.0, 1 - D.normal[a] * D.normal[a]));
        frame(D.normal, e1, e2);
        int i0[3], i1[3];
        for (int a = 0; a < 3; ++a) {
            i0[a] = int(std::ceil((lo[a] - ext[a] - D.center[a]) / size));
            i1[a] = int(std::floor((hi[a] + ext[a] - D.center[a]) / size));
        }
        for (int i = i0[0]; i <= i1[0]; ++i)
            for (int j = i0[1]; j <= i1[1]; ++j)
                for (int k = i0[2]; k <= i1[2]; ++k) {
                    const Vec3d c = D.center + Vec3d(i, j, k) * size;
                    // The plane must cut the box: box corners on both sides.
                    double hmin = 0, hmax = 0;
                    for (int a = 0; a < 3; ++a) {
                        const double t0 = D.normal[a] * (lo[a] - c[a]), t1 = D.normal[a] * (hi[a] - c[a]);
                        hmin += std::min(t0, t1);
                        hmax += std::max(t0, t1);
                    }
                    if (hmin >= 0 || hmax < 0) continue;
                    plus.clear();
                    minus.clear();
                    double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
                    for (const auto& p : P) {
                        const Vec3d w = p - c;
                        const Lifted l{w.dot(e1), w.dot(e2), w.dot(D.normal)};
                        u0 = std::min(u0, l.u); u1 = std::max(u1, l.u);
                        v0 = std::min(v0, l.v); v1 = std::max(v1, l.v);
                        (l.h >= 0 ? plus : minus).push_back(l);
                    }
                    if (plus.empty() || minus.empty()) continue;
                    const double r2 = D.radius * D.radius;
                    // Crossing points lie on segments between the points, hence inside the
                    // box of their in-plane coordinates: the disc must meet that box.
                    const double du = std::max({0.0, u0, -u1}), dv = std::max({0.0, v0, -v1});
                    if (du * du + dv * dv >= r2) continue;
                    auto nearest = [](std::vector<Lifted>& from, std::vector<Lifted>& out) {
                        const size_t m = std::min<size_t>(32, from.size());
                        out.assign(from.begin(), from.end());
                        std::nth_element(out.begin(), out.begin() + long(m - 1), out.end(),
                                         [](const Lifted& a, const Lifted& b) {
                                             return a.u * a.u + a.v * a.v < b.u * b.u + b.v * b.v;
                                         });
                        out.resize(m);
                    };
                    nearest(plus, nearPlus);
                    nearest(minus, nearMinus);
                    if (anyCrossing(nearPlus, nearMinus, r2) || anyCrossing(plus, minus, r2)) {
                        imageCentre = c;
                        return int(d);
                    }
                }
    }
    return -1;
}

// Anchors: the centroid, then farthest-point samples of the cluster (deterministic).
std::vector<std::array<float, 3>> anchorsOf(const std::vector<Vec3d>& P, const Vec3d& centroid,
                                            size_t count)
{
    std::vector<std::array<float, 3>> out;
    out.push_back({float(centroid[0]), float(centroid[1]), float(centroid[2])});
    std::vector<double> dist(P.size(), std::numeric_limits<double>::max());
    Vec3d last = centroid;
    for (size_t k = 1; k < count && k <= P.size(); ++k) {
        size_t best = 0;
        double bestD = -1;
        for (size_t i = 0; i < P.size(); ++i) {
            dist[i] = std::min(dist[i], (P[i] - last).lengthSqr());
            if (dist[i] > bestD) { bestD = dist[i]; best = i; }
        }
        // Pull the sample half-way to the centroid so it stays inside the block.
        last = P[best];
        const Vec3d a = (P[best] + centroid) * 0.5;
        out.push_back({float(a[0]), float(a[1]), float(a[2])});
    }
    return out;
}

// Block geometry from a cluster (unwrapped points, home frame).
Block makeBlock(const std::vector<Vec3d>& P, double thickness, double smoothRadius)
{
    Block b;
    b.points = int(P.size());
    Vec3d centroid(0);
    for (const auto& p : P) centroid += p;
    centroid /= double(P.size());
    const Hull hull = convexHull(P, 1e-6 * std::max(1.0, thickness));
    Vec3d lo = P[0], hi = P[0];
    for (const auto& p : P) { lo = minComponent(lo, p); hi = maxComponent(hi, p); }
    const double t = 0.5 * thickness;
    if (hull.dimension == 3) {
        // Fold order: largest facets first, so near a face its plane dominates early and the
        // evaluator can skip the later, dominated ones exactly.
        std::vector<size_t> order(hull.planes.size());
        std::iota(order.begin(), order.end(), 0);
        std::stable_sort(order.begin(), order.end(),
                         [&](size_t a, size_t c) { return hull.areas[a] > hull.areas[c]; });
        for (size_t k : order) {
            const auto& q = hull.planes[k];
            b.planes.push_back({float(q[0]), float(q[1]), float(q[2]), float(q[3])});
            b.areas.push_back(float(hull.areas[k]));
        }
        for (const auto& v : hull.vertices) b.vertices.push_back(f3(v));
    } else if (hull.dimension == 2) {
        // Thick polygon: the flat cluster's 2D hull extruded by ±t.
        const Vec3d p0 = P[0];
        size_t i1 = 0;
        for (size_t i = 0; i < P.size(); ++i)
            if ((P[i] - p0).lengthSqr() > (P[i1] - p0).lengthSqr()) i1 = i;
        const Vec3d e1 = (P[i1] - p0).unit();
        Vec3d n(0);
        for (const auto& p : P) {
            const Vec3d c = e1.cross(p - p0);
            if (c.lengthSqr() > n.lengthSqr()) n = c;
        }
        n = n.unit();
        const Vec3d e2 = n.cross(e1);
        std::vector<std::array<double, 2>> q;
        for (const auto& p : P) q.push_back({(p - p0).dot(e1), (p - p0).dot(e2)});
        const std::vector<int> h = hull2d(q);
        const double off = n.dot(p0);
        b.planes.push_back({float(n[0]), float(n[1]), float(n[2]), float(off + t)});
        b.planes.push_back({float(-n[0]), float(-n[1]), float(-n[2]), float(-off + t)});
        for (size_t k = 0; k < h.size(); ++k) {
            const auto& a = q[size_t(h[k])];
            const auto& c = q[size_t(h[(k + 1) % h.size()])];
            // Outward in-plane normal of a counter-clockwise edge: (dy, -dx).
            const double ex = c[0] - a[0], ey = c[1] - a[1], len = std::hypot(ex, ey);
            if (len <= 0) continue;
            const Vec3d m = (e1 * ey - e2 * ex) / len;
            const Vec3d pa = p0 + e1 * a[0] + e2 * a[1];
            b.planes.push_back({float(m[0]), float(m[1]), float(m[2]), float(m.dot(pa))});
        }
        // The smooth intersection raises the value by at most R/6 per fold step: push every
        // plane out by R·(n - 1)/6 so the rounded slab still holds the cluster's points
        // (a small flat block would otherwise round away).
        const float push = float(smoothRadius * double(b.planes.size() - 1) / 6.0);
        for (auto& pl : b.planes) pl[3] += push;
        for (const auto& i : h) {
            const Vec3d pa = p0 + e1 * q[size_t(i)][0] + e2 * q[size_t(i)][1];
            b.vertices.push_back(f3(pa + n * t));
            b.vertices.push_back(f3(pa - n * t));
        }
        lo -= Vec3d(double(push));
        hi += Vec3d(double(push));
    } else if (hull.dimension == 1) {
        size_t i0 = 0, i1 = 0;
        for (size_t i = 0; i < P.size(); ++i) {
            if ((P[i] - P[0]).lengthSqr() > (P[i1] - P[0]).lengthSqr()) i1 = i;
        }
        for (size_t i = 0; i < P.size(); ++i) {
            if ((P[i] - P[i1]).lengthSqr() > (P[i0] - P[i1]).lengthSqr()) i0 = i;
        }
        b.kind = BlockKind::Segment;
        b.a = f3(P[i0]);
        b.b = f3(P[i1]);
        b.radius = float(t);
    } else {
        b.kind = BlockKind::Point;
        b.a = b.b = f3(centroid);
        b.radius = float(t);
    }
    b.anchors = anchorsOf(P, centroid, 16);
    for (const auto& q : P) b.cluster.push_back(f3(q));
    lo -= Vec3d(t);
    hi += Vec3d(t);
    b.boundsMin = f3(lo);
    b.boundsMax = f3(hi);
    return b;
}

namespace {

// An expression block: its bounds are the expression's; its anchors are inside samples of a
// 16³ grid over them (the expression need not be convex, so anchorsOf's pull towards the
// centroid could leave it): the deepest sample first, then farthest-point samples.
Block makeExpressionBlock(const AuthoredBlock& a, const std::vector<Vec3d>& inside)
{
    Block b;
    b.authored = true;
    b.kind = BlockKind::Expression;
    b.expression = a.expression;
    b.points = int(inside.size());
    const FieldPtr f = a.field ? a.field : authoredExpressionField(a.expression, "authored block");
    const BBoxd bb = f->bounds();
    constexpr int kGrid = 16;
    BatchBuffer buf;
    std::vector<Vec3d> samples;
    std::vector<float> depth;
    alignas(64) float v[kMaxBatch];
    for (int i = 0; i < kGrid; ++i) {
        buf.n = 0;
        for (int j = 0; j < kGrid; ++j)
            for (int k = 0; k < kGrid; ++k) {
                const Vec3d q = bb.min() + bb.extents() * Vec3d((i + 0.5) / kGrid, (j + 0.5) / kGrid,
                                                                 (k + 0.5) / kGrid);
                buf.x[buf.n] = float(q[0]);
                buf.y[buf.n] = float(q[1]);
                buf.z[buf.n] = float(q[2]);
                ++buf.n;
            }
        f->evalBatch(buf.view(), v);
        for (int m = 0; m < buf.n; ++m) {
            if (v[m] <= 0.0f) {
                samples.emplace_back(buf.x[m], buf.y[m], buf.z[m]);
                depth.push_back(v[m]);
            }
        }
    }
    if (samples.empty()) {
        fail<ValueError>("blocks: an authored expression block is thinner than 1/16 of its "
                         "bounds (", bb.extents().length(), " m across): no inside sample");
    }
    const size_t deepest = size_t(std::min_element(depth.begin(), depth.end()) - depth.begin());
    b.anchors.push_back(f3(samples[deepest]));
    std::vector<double> dist(samples.size(), std::numeric_limits<double>::max());
    Vec3d last = samples[deepest];
    for (size_t k = 1; k < 16 && k < samples.size(); ++k) {
        size_t best = 0;
        double bestD = -1;
        for (size_t i = 0; i < samples.size(); ++i) {
            dist[i] = std::min(dist[i], (samples[i] - last).lengthSqr());
            if (dist[i] > bestD) { bestD = dist[i]; best = i; }
        }
        last = samples[best];
        b.anchors.push_back(f3(last));
    }
    for (const auto& q : inside) b.cluster.push_back(f3(q));
    b.boundsMin = f3(bb.min());
    b.boundsMax = f3(bb.max());
    return b;
}

} // namespace

// An authored block's planes (normalised) and geometry; its vertices by plane triples.
Block makeAuthored(const AuthoredBlock& a, const std::vector<Vec3d>& inside)
{
    if (a.isExpression()) return makeExpressionBlock(a, inside);
    Block b;
    b.authored = true;
    b.points = int(inside.size());
    std::vector<std::array<double, 4>> planes;
    for (const auto& q : a.planes) {
        const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        planes.push_back({q[0] / len, q[1] / len, q[2] / len, q[3] / len});
        b.planes.push_back({float(q[0] / len), float(q[1] / len), float(q[2] / len),
                            float(q[3] / len)});
    }
    // Vertices: intersections of plane triples inside every half-space.
    std::vector<Vec3d> verts;
    for (size_t i = 0; i < planes.size(); ++i)
        for (size_t j = i + 1; j < planes.size(); ++j)
            for (size_t k = j + 1; k < planes.size(); ++k) {
                const Vec3d n1(planes[i][0], planes[i][1], planes[i][2]),
                    n2(planes[j][0], planes[j][1], planes[j][2]),
                    n3(planes[k][0], planes[k][1], planes[k][2]);
                const double det = n1.dot(n2.cross(n3));
                if (std::abs(det) < 1e-9) continue;
                const Vec3d x = (n2.cross(n3) * planes[i][3] + n3.cross(n1) * planes[j][3] +
                                 n1.cross(n2) * planes[k][3]) / det;
                bool ok = true;
                for (const auto& q : planes) {
                    if (q[0] * x[0] + q[1] * x[1] + q[2] * x[2] > q[3] + 1e-7) ok = false;
                }
                if (ok) verts.push_back(x);
            }
    if (verts.empty()) fail<ValueError>("blocks: authored block has no vertices (empty)");
    Vec3d lo = verts[0], hi = verts[0], centroid(0);
    for (const auto& v : verts) {
        lo = minComponent(lo, v);
        hi = maxComponent(hi, v);
        b.vertices.push_back(f3(v));
    }
    for (const auto& v : inside) centroid += v;
    if (inside.empty()) {
        for (const auto& v : verts) centroid += v;
        centroid /= double(verts.size());
    } else {
        centroid /= double(inside.size());
    }
    b.anchors = anchorsOf(inside.empty() ? verts : inside, centroid, 16);
    for (const auto& q : inside) b.cluster.push_back(f3(q));
    b.boundsMin = f3(lo);
    b.boundsMax = f3(hi);
    return b;
}

// Inside test of an authored block, for the periodic image nearest the point; returns the
// unwrapped position (or false).
bool insideAuthored(const AuthoredBlock& a, const Vec3d& p, double size, Vec3d& unwrapped)
{
    if (a.isExpression()) {
        const BBoxd bb = a.field->bounds();
        for (int i = -1; i <= 1; ++i)
            for (int j = -1; j <= 1; ++j)
                for (int k = -1; k <= 1; ++k) {
                    const Vec3d q = p + Vec3d(i, j, k) * size;
                    if (bb.isInside(q) && a.field->eval(q) <= 0.0f) { unwrapped = q; return true; }
                }
        return false;
    }
    for (int i = -1; i <= 1; ++i)
        for (int j = -1; j <= 1; ++j)
            for (int k = -1; k <= 1; ++k) {
                const Vec3d q = p + Vec3d(i, j, k) * size;
                bool in = true;
                for (const auto& pl : a.planes) {
                    if (pl[0] * q[0] + pl[1] * q[1] + pl[2] * q[2] > pl[3]) { in = false; break; }
                }
                if (in) { unwrapped = q; return true; }
            }
    return false;
}

// Move a block so its first anchor (the centroid) lies in [0, s)³.
void translate(Block& b, const Vec3d& shift)
{
    auto move = [&](std::array<float, 3>& v) {
        for (int a = 0; a < 3; ++a) v[size_t(a)] = float(double(v[size_t(a)]) + shift[a]);
    };
    for (auto& pl : b.planes) {
        pl[3] = float(double(pl[3]) + double(pl[0]) * shift[0] + double(pl[1]) * shift[1] +
                      double(pl[2]) * shift[2]);
    }
    move(b.a);
    move(b.b);
    move(b.origin);
    for (auto& v : b.vertices) move(v);
    for (auto& v : b.cluster) move(v);
    for (auto& v : b.anchors) move(v);
    move(b.boundsMin);
    move(b.boundsMax);
}

void toHome(Block& b, double size)
{
    Vec3d shift;
    for (int a = 0; a < 3; ++a) shift[a] = -size * std::floor(double(b.anchors[0][size_t(a)]) / size);
    if (shift == Vec3d(0)) return;
    translate(b, shift);
}

} // namespace tilegen
} // namespace blocks
} // namespace rockvdb
