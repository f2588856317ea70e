// SPDX-License-Identifier: Apache-2.0
// Swept volumes for cracks and tunnels (see Sweep.h).
#include "Sweep.h"

#include <rockvdb/core/Error.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace rockvdb {
namespace arches {

namespace {

Vec3d unit(const Vec3d& v, const Vec3d& fallback)
{
    const double l = v.length();
    return l > 1e-12 ? v / l : fallback;
}

// Signed distance from q to a closed polygon (positive inside; crossing-number inside test).
double polygonDistance(const std::vector<Vec2d>& poly, const Vec2d& q)
{
    double best = std::numeric_limits<double>::infinity();
    bool in = false;
    const size_t n = poly.size();
    for (size_t i = 0, j = n - 1; i < n; j = i++) {
        const Vec2d& a = poly[j];
        const Vec2d& b = poly[i];
        if (((b[1] > q[1]) != (a[1] > q[1])) && (q[0] < (a[0] - b[0]) * (q[1] - b[1]) / (a[1] - b[1]) + b[0])) in = !in;
        const Vec2d e = b - a, w = q - a;
        const double l2 = e.lengthSqr();
        const double t = l2 > 0 ? std::clamp(w.dot(e) / l2, 0.0, 1.0) : 0.0;
        best = std::min(best, (w - e * t).lengthSqr());
    }
    const double d = std::sqrt(best);
    return in ? d : -d;
}

} // namespace

std::vector<Vec2d> sampleProfile(const std::vector<Vec2d>& c, bool spline, int count)
{
    const size_t m = c.size();
    if (m < 3) fail<ValueError>("sweep: a profile needs at least 3 points (got ", m, ")");
    count = std::max(count, int(m));
    // Each span (control point k to k + 1) densely, for its length.
    const int per = 64;
    auto point = [&](size_t k, double t) {
        const Vec2d& p0 = c[(k + m - 1) % m];
        const Vec2d& p1 = c[k];
        const Vec2d& p2 = c[(k + 1) % m];
        const Vec2d& p3 = c[(k + 2) % m];
        if (!spline) return p1 + (p2 - p1) * t;
        const double t2 = t * t, t3 = t2 * t;
        return (p1 * 2.0 + (p2 - p0) * t + (p0 * 2.0 - p1 * 5.0 + p2 * 4.0 - p3) * t2 +
                (p1 * 3.0 - p0 - p2 * 3.0 + p3) * t3) * 0.5;
    };
    std::vector<std::vector<double>> at(m); // arc length along each span at per + 1 samples
    std::vector<double> spanLength(m);
    double total = 0;
    for (size_t k = 0; k < m; ++k) {
        at[k].assign(per + 1, 0.0);
        for (int s2 = 1; s2 <= per; ++s2) {
            at[k][size_t(s2)] = at[k][size_t(s2) - 1] + (point(k, double(s2) / per) - point(k, double(s2 - 1) / per)).length();
        }
        spanLength[k] = at[k][per];
        total += spanLength[k];
    }
    if (!(total > 0)) fail<ValueError>("sweep: a profile has no extent");
    // Samples per span in proportion to its length, at least one (its control point, so a
    // polygon's corners stay corners), summing to count (largest remainders).
    std::vector<int> n(m, 1);
    int used = int(m);
    std::vector<std::pair<double, size_t>> rest;
    for (size_t k = 0; k < m; ++k) {
        const double want = double(count) * spanLength[k] / total;
        const int extra = std::max(0, int(std::floor(want)) - 1);
        n[k] += extra;
        used += extra;
        rest.emplace_back(want - std::floor(want), k);
    }
    std::stable_sort(rest.begin(), rest.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
    for (size_t r = 0; used < count; r = (r + 1) % m, ++used) ++n[rest[r].second];
    std::vector<Vec2d> out;
    for (size_t k = 0; k < m; ++k) {
        // n[k] points evenly along the span's length, the first at its control point.
        size_t q = 0;
        for (int s2 = 0; s2 < n[k]; ++s2) {
            const double want = spanLength[k] * s2 / n[k];
            while (q + 1 < size_t(per) && at[k][q + 1] <= want) ++q;
            const double span = at[k][q + 1] - at[k][q];
            const double f = span > 0 ? (want - at[k][q]) / span : 0.0;
            out.push_back(point(k, (double(q) + f) / per));
        }
    }
    return out;
}

SweepVolume::SweepVolume(const SweepSpec& spec) : mProfiles(spec.profiles)
{
    const size_t nodes = spec.nodes.size();
    std::vector<int> degree(nodes, 0);
    for (const auto& [a, b] : spec.arcs) {
        ++degree[size_t(a)];
        ++degree[size_t(b)];
    }
    auto place = [&](const Vec3d& p) { return spec.place ? spec.place(p) : p; };
    // Tangent at a node shared by exactly two arcs: the bisector, so both arcs end in the same
    // cross-section there (no wedge at a bend).
    std::vector<Vec3d> placed(nodes);
    for (size_t n = 0; n < nodes; ++n) placed[n] = place(spec.nodes[n]);
    std::vector<Vec3d> bisector(nodes, Vec3d(0));
    for (size_t n = 0; n < nodes; ++n) {
        if (degree[n] != 2) continue;
        Vec3d sum(0);
        int seen = 0;
        for (const auto& [a, b] : spec.arcs) {
            if (size_t(a) == n) sum += unit(placed[size_t(b)] - placed[n], Vec3d(1, 0, 0)) * (seen++ == 0 ? -1.0 : 1.0);
            else if (size_t(b) == n) sum += unit(placed[n] - placed[size_t(a)], Vec3d(1, 0, 0)) * (seen++ == 0 ? 1.0 : -1.0);
        }
        bisector[n] = sum; // direction up to sign; oriented per arc below
    }
    auto frame = [&](const Vec3d& origin, const Vec3d& t) {
        Section s;
        s.origin = origin;
        s.t = t;
        const Vec3d up = spec.normal ? spec.normal(origin) : Vec3d(0, 0, 1);
        Vec3d n = up - t * up.dot(t);
        if (n.length() < 1e-6) {
            const Vec3d alt = std::abs(t[0]) < 0.9 ? Vec3d(1, 0, 0) : Vec3d(0, 1, 0);
            n = alt - t * alt.dot(t);
        }
        s.n = unit(n, Vec3d(0, 0, 1));
        s.b = t.cross(s.n);
        return s;
    };
    // Refuse a step that would need absurdly many cross-sections, before allocating any.
    double sections = 0;
    for (const auto& [a, b] : spec.arcs) {
        sections += std::ceil((spec.nodes[size_t(b)] - spec.nodes[size_t(a)]).length() / spec.step);
    }
    if (!(sections <= double(kMaxPrisms))) {
        fail<ValueError>("sweep: ", sections, " cross-sections (the arcs' length over a step of ", spec.step,
                         " m), more than ", kMaxPrisms, "; use a larger step");
    }
    mBounds = BBoxd();
    bool first = true;
    for (const auto& [a, b] : spec.arcs) {
        const Vec3d A = spec.nodes[size_t(a)], B = spec.nodes[size_t(b)];
        const int K = std::max(1, int(std::ceil((B - A).length() / spec.step)));
        std::vector<Vec3d> pts(size_t(K) + 1);
        for (int k = 0; k <= K; ++k) pts[size_t(k)] = place(A + (B - A) * (double(k) / K));
        const Vec3d along = unit(pts.back() - pts.front(), Vec3d(1, 0, 0));
        std::vector<Section> sec(size_t(K) + 1);
        for (int k = 0; k <= K; ++k) {
            Vec3d t;
            if (k == 0 && degree[size_t(a)] == 2) t = bisector[size_t(a)];
            else if (k == K && degree[size_t(b)] == 2) t = bisector[size_t(b)];
            else t = pts[size_t(std::min(k + 1, K))] - pts[size_t(std::max(k - 1, 0))];
            t = unit(t, along);
            if (t.dot(along) < 0) t = -t;
            sec[size_t(k)] = frame(pts[size_t(k)], t);
        }
        const int pa = spec.nodeProfile[size_t(a)], pb = spec.nodeProfile[size_t(b)];
        for (int k = 0; k < K; ++k) {
            Prism q;
            q.a = sec[size_t(k)];
            q.b = sec[size_t(k) + 1];
            // Profiles blend along the arc: the prism's ends carry their share of each.
            q.a.profile = pa;
            q.b.profile = pb;
            q.lo = (k > 0 || degree[size_t(a)] >= 2) ? -0.5 : 0.0;
            q.hi = (k < K - 1 || degree[size_t(b)] >= 2) ? 1.5 : 1.0;
            // Where this prism's ends sit along the arc, for the profile blend.
            const double wa = double(k) / K, wb = double(k + 1) / K;
            q.wa = wa;
            q.wb = wb;
            q.box = BBoxd();
            bool empty = true;
            for (const double s : {q.lo, 0.0, 1.0, q.hi}) {
                const double w = wa + (wb - wa) * std::clamp(s, 0.0, 1.0);
                const Vec3d o = q.a.origin + (q.b.origin - q.a.origin) * s;
                const Vec3d nn = s < 0.5 ? q.a.n : q.b.n, bb = s < 0.5 ? q.a.b : q.b.b;
                for (size_t v = 0; v < mProfiles[size_t(pa)].size(); ++v) {
                    const Vec2d uv = mProfiles[size_t(pa)][v] * (1.0 - w) + mProfiles[size_t(pb)][v] * w;
                    const Vec3d p = o + bb * uv[0] + nn * uv[1];
                    if (empty) {
                        q.box = BBoxd(p, p);
                        empty = false;
                    } else {
                        q.box.expand(p);
                    }
                }
            }
            if (first) {
                mBounds = q.box;
                first = false;
            } else {
                mBounds.expand(q.box);
            }
            mPrisms.push_back(q);
        }
    }
}

double SweepVolume::prismInside(const Prism& q, const Vec3d& p) const
{
    // Where p lies between the two cross-section planes: s = d_a / (d_a − d_b), the signed
    // distances to each plane along its own tangent. At a bend the planes tilt towards each
    // other; measuring s along the axis instead left a wedge uncovered on the outer side (a
    // fin across a ravine at each bend). Where the planes cross (d_a − d_b <= 0, far on the
    // inner side of a bend) this prism covers nothing: its neighbours do.
    const Vec3d axis = q.b.origin - q.a.origin;
    const double L = axis.length();
    const double da = (p - q.a.origin).dot(q.a.t), db = (p - q.b.origin).dot(q.b.t);
    const double den = da - db;
    if (!(den > 1e-12)) return -std::numeric_limits<double>::infinity();
    const double s = da / den;
    if (s < q.lo) return -(q.lo - s) * L;
    if (s > q.hi) return -(s - q.hi) * L;
    const double sc = std::clamp(s, 0.0, 1.0);
    const Vec3d o = q.a.origin + axis * s;
    const Vec3d n = unit(q.a.n * (1.0 - sc) + q.b.n * sc, q.a.n);
    const Vec3d b = unit(q.a.b * (1.0 - sc) + q.b.b * sc, q.a.b);
    const Vec2d uv((p - o).dot(b), (p - o).dot(n));
    // The cross-section at s: the two node profiles blended by the position along the arc.
    const double w = q.wa + (q.wb - q.wa) * sc;
    const auto& A = mProfiles[size_t(q.a.profile)];
    const auto& B = mProfiles[size_t(q.b.profile)];
    thread_local std::vector<Vec2d> shape;
    shape.resize(A.size());
    for (size_t v = 0; v < A.size(); ++v) shape[v] = A[v] * (1.0 - w) + B[v] * w;
    const double d2 = polygonDistance(shape, uv);
    return std::min(d2, std::min(s - q.lo, q.hi - s) * L);
}

double SweepVolume::inside(const Vec3d& p, const std::vector<uint32_t>& prisms) const
{
    double best = -std::numeric_limits<double>::infinity();
    for (const uint32_t k : prisms) {
        const Prism& q = mPrisms[k];
        if (p[2] < q.box.min()[2]) {
            best = std::max(best, p[2] - q.box.min()[2]);
            continue;
        }
        if (p[2] > q.box.max()[2]) {
            best = std::max(best, q.box.max()[2] - p[2]);
            continue;
        }
        best = std::max(best, prismInside(q, p));
    }
    return best;
}

std::vector<uint32_t> SweepVolume::candidates(double x, double y) const
{
    std::vector<uint32_t> out;
    for (uint32_t k = 0; k < mPrisms.size(); ++k) {
        const BBoxd& b = mPrisms[k].box;
        if (x >= b.min()[0] && x <= b.max()[0] && y >= b.min()[1] && y <= b.max()[1]) out.push_back(k);
    }
    return out;
}

std::pair<double, double> SweepVolume::zRange(const std::vector<uint32_t>& prisms) const
{
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const uint32_t k : prisms) {
        lo = std::min(lo, mPrisms[k].box.min()[2]);
        hi = std::max(hi, mPrisms[k].box.max()[2]);
    }
    return {lo, hi};
}

} // namespace arches
} // namespace rockvdb
