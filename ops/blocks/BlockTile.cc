// Tile generation (§4.1 fracturing, §4.2 convex bases) and the tile file.
#include "BlockTile.h"

#include "Hull.h"

#include <core/Error.h>
#include <core/Random.h>
#include <core/Sampling.h>
#include <core/VdbIO.h>

#include <nlohmann/json.hpp>
#include <openvdb/io/File.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <tuple>
#include <deque>
#include <map>
#include <fstream>
#include <numeric>
#include <sstream>

namespace rockvdb {
namespace blocks {

using nlohmann::json;

namespace {

// Random streams (one per independent quantity, see core/Random.h).
enum Stream : uint64_t {
    kPoints = 1, kDiscCentres = 2, kDiscShape = 3, kBedding = 4, kAnchors = 5, kFrame = 6
};

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0)
{
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

const char* kTypeNames[] = {"equidimensional", "prismatic", "polyhedral",
                            "rhombohedral",    "tabular",   "columnar"};

// Orthonormal frame (e1, e2, u) around the unit axis u.
void frame(const Vec3d& u, Vec3d& e1, Vec3d& e2)
{
    const Vec3d helper = std::abs(u[0]) < 0.9 ? Vec3d(1, 0, 0) : Vec3d(0, 1, 0);
    e1 = helper.cross(u).unit();
    e2 = u.cross(e1);
}

// Uniform unit vector from two uniforms.
Vec3d unitVector(double a, double b)
{
    const double z = 2 * a - 1, phi = 2 * M_PI * b, s = std::sqrt(std::max(0.0, 1 - z * z));
    return Vec3d(s * std::cos(phi), s * std::sin(phi), z);
}

// Tilt n by an angle up to maxDeg about a random perpendicular axis.
Vec3d jitter(const Vec3d& n, double maxDeg, double a, double b)
{
    if (maxDeg <= 0) return n;
    Vec3d e1, e2;
    frame(n, e1, e2);
    const double angle = maxDeg * M_PI / 180.0 * std::sqrt(a), phi = 2 * M_PI * b;
    const Vec3d perp = e1 * std::cos(phi) + e2 * std::sin(phi);
    return (n * std::cos(angle) + perp * std::sin(angle)).unit();
}

bool finite3(const Vec3d& v)
{
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

// ---- fracture discs per block type (§4.1) ----------------------------------------------

std::vector<Disc> makeDiscs(const TileParams& p)
{
    const double s = p.tileSize;
    const Vec3d u = p.axis.unit();
    Vec3d e1, e2;
    frame(u, e1, e2);
    // A random rotation of the set directions about the axis, fixed per seed.
    const double spin = 2 * M_PI * random::uniform(p.seed, kFrame, 0);
    const Vec3d f1 = e1 * std::cos(spin) + e2 * std::sin(spin);
    const Vec3d f2 = u.cross(f1);

    std::vector<Vec3d> centres = dartsPeriodic(s, p.discSpacing, p.discCount, p.seed, kDiscCentres);
    std::vector<Disc> discs;
    auto rnd = [&](size_t i, uint64_t k) { return random::uniform(p.seed, kDiscShape, i * 8 + k); };
    auto radius = [&](size_t i) {
        return p.discRadiusMin + (p.discRadiusMax - p.discRadiusMin) * rnd(i, 0);
    };
    auto irregular = [&](size_t i) { return rnd(i, 1) < p.irregularFraction; };
    auto randomNormal = [&](size_t i) { return unitVector(rnd(i, 2), rnd(i, 3)); };
    // Disc i of a set of evenly spaced fractures (sets take discs in turn): its offset along
    // the set normal is stratified, k-th of m, jittered by a quarter spacing; its position
    // across the set is uniform.
    const size_t perSet = std::max<size_t>(1, (centres.size() + 2) / 3);
    auto inSet = [&](size_t i, const Vec3d& n) {
        Vec3d a, b;
        frame(n, a, b);
        const double k = double(i / 3) + 0.5 + 0.5 * (rnd(i, 7) - 0.5);
        Vec3d c = n * (k * s / double(perSet)) + a * (s * rnd(i, 2)) + b * (s * rnd(i, 3));
        for (int ax = 0; ax < 3; ++ax) c[ax] -= s * std::floor(c[ax] / s);
        return c;
    };

    // Three sets of discs taken in turn, evenly spaced along their (jittered) normals, plus
    // the irregular share with random normals (equidimensional, prismatic, rhombohedral).
    auto threeSets = [&](const Vec3d (&dirs)[3]) {
        for (size_t i = 0; i < centres.size(); ++i) {
            if (irregular(i)) {
                discs.push_back({centres[i], randomNormal(i), radius(i)});
                continue;
            }
            const int set = int(i % 3);
            discs.push_back({inSet(i, dirs[set]),
                             jitter(dirs[set], p.jitterDeg, rnd(i, 5), rnd(i, 6)), radius(i)});
        }
    };

    switch (p.type) {
    case BlockType::Equidimensional:
    case BlockType::Prismatic: {
        // Three approximately orthogonal, evenly spaced sets (§3: "a family of parallel,
        // evenly spaced fractures"; discs assigned to the sets in turn, stratified along the
        // set normal) plus occasional irregular fractures; prismatic differs only by its
        // larger jitter and irregular share (its defaults): "slightly more irregular".
        // Exactly the frame's axes (the tile's axes for the default axis z): a set normal
        // that is not a lattice direction meets its own periodic images at other offsets,
        // and the gaps between them become sliver blocks.
        const Vec3d dirs[3] = {e1, e2, u};
        threeSets(dirs);
        break;
    }
    case BlockType::Polyhedral:
        // No arrangement into sets: uniformly random normals, dense small discs.
        for (size_t i = 0; i < centres.size(); ++i) {
            discs.push_back({centres[i], randomNormal(i), radius(i)});
        }
        break;
    case BlockType::Rhombohedral: {
        // Three mutually oblique sets: unit normals at polar angle β around the axis, 120°
        // apart in azimuth, with pairwise angle θ: cos θ = 1 - 1.5 sin²β (θ = 90° gives the
        // equidimensional cube tilted onto its diagonal; the default θ = 60° a rhombohedron).
        const double cosT = std::cos(p.obliqueDeg * M_PI / 180.0);
        const double sinB = std::sqrt((1.0 - cosT) / 1.5), cosB = std::sqrt(1 - sinB * sinB);
        Vec3d dirs[3];
        for (int k = 0; k < 3; ++k) {
            const double az = 2 * M_PI * k / 3.0;
            dirs[k] = (u * cosB + (f1 * std::cos(az) + f2 * std::sin(az)) * sinB).unit();
        }
        threeSets(dirs);
        break;
    }
    case BlockType::Tabular: {
        // One dominant set of bedding planes orthogonal to the axis with radius s (they cross
        // the whole periodic tile), at stratified heights so beds have comparable thickness;
        // the other discs are small (s/10) and parallel to the two orthogonal axes.
        const int beds = std::max(1, int(std::lround(p.discCount / 3.0)));
        const Vec3d origin(0);
        for (int k = 0; k < beds; ++k) {
            const double h = (k + 0.25 + 0.5 * random::uniform(p.seed, kBedding, uint64_t(k))) *
                             s / beds;
            const Vec3d c = origin + u * h + f1 * (s * random::uniform(p.seed, kBedding, 1000 + k)) +
                            f2 * (s * random::uniform(p.seed, kBedding, 2000 + k));
            // No tilt: a tilted disc of radius s would meet its own periodic images as
            // stacked sheets (slivers) instead of one bedding plane.
            discs.push_back({c, u, s});
        }
        const size_t small = size_t(std::max(0, p.discCount - beds));
        for (size_t i = 0; i < centres.size() && i < small; ++i) {
            const Vec3d n = jitter(rnd(i, 4) < 0.5 ? f1 : f2, p.jitterDeg, rnd(i, 5), rnd(i, 6));
            discs.push_back({centres[i], n, radius(i)});
        }
        break;
    }
    case BlockType::Columnar: {
        // Columnar jointing (basalt colonnades): three sets of long, continuous fractures
        // parallel to the column axis, their normals 60° apart in the plane orthogonal to it
        // (the hexagonal habit of cooling joints), so columns are polygonal prisms much
        // longer than wide; a few short cross-joints orthogonal to the axis break them into
        // long segments (the irregular share of the discs).
        for (size_t i = 0; i < centres.size(); ++i) {
            if (irregular(i)) {
                discs.push_back({centres[i], jitter(u, p.jitterDeg, rnd(i, 5), rnd(i, 6)),
                                 0.5 * radius(i)});
            } else {
                // Jitter the azimuth only: the normal stays orthogonal to the axis, so the
                // long discs stay coplanar with their images along the column.
                const int set = int(i % 3);
                const double az = M_PI * set / 3.0 + (2 * rnd(i, 5) - 1) * p.jitterDeg * M_PI / 180.0;
                const Vec3d n = f1 * std::cos(az) + f2 * std::sin(az);
                discs.push_back({inSet(i, n), n, radius(i)});
            }
        }
        break;
    }
    }
    for (const auto& d : p.extraDiscs) discs.push_back({d.center, d.normal.unit(), d.radius});
    return discs;
}

// Does the segment pq cross the disc (centre c, unit normal n, radius r)?
inline bool crosses(const Vec3d& p, const Vec3d& q, const Vec3d& c, const Vec3d& n, double r)
{
    const double dp = n.dot(p - c), dq = n.dot(q - c);
    if ((dp >= 0) == (dq >= 0)) return false;
    const double t = dp / (dp - dq);
    return (p + (q - p) * t - c).lengthSqr() < r * r;
}

// Periodic images of the discs, bucketed on a grid over the tile for segment queries.
class DiscGrid
{
public:
    DiscGrid(const std::vector<Disc>& discs, double size, double margin)
        : mDiscs(discs), mSize(size)
    {
        mN = std::max(1, std::min(16, int(size / 2.0)));
        mCell = size / mN;
        mCells.resize(size_t(mN) * mN * mN);
        for (size_t d = 0; d < discs.size(); ++d) {
            const Disc& D = discs[d];
            // Disc bounding box: r·sqrt(1 - n_a²) around c along axis a.
            Vec3d ext;
            for (int a = 0; a < 3; ++a) {
                ext[a] = D.radius * std::sqrt(std::max(0.0, 1 - D.normal[a] * D.normal[a])) + margin;
            }
            const int reach = int(std::ceil((D.radius + margin) / size)) + 1;
            for (int i = -reach; i <= reach; ++i)
                for (int j = -reach; j <= reach; ++j)
                    for (int k = -reach; k <= reach; ++k) {
                        const Vec3d c = D.center + Vec3d(i, j, k) * size;
                        int lo[3], hi[3];
                        bool inside = true;
                        for (int a = 0; a < 3; ++a) {
                            lo[a] = std::max(0, int(std::floor((c[a] - ext[a]) / mCell)));
                            hi[a] = std::min(mN - 1, int(std::floor((c[a] + ext[a]) / mCell)));
                            if (lo[a] > hi[a]) inside = false;
                        }
                        if (!inside) continue;
                        for (int x = lo[0]; x <= hi[0]; ++x)
                            for (int y = lo[1]; y <= hi[1]; ++y)
                                for (int z = lo[2]; z <= hi[2]; ++z) {
                                    mCells[(size_t(x) * mN + y) * mN + z].push_back(
                                        {int(d), c});
                                }
                    }
        }
    }

    // Does segment pq (|pq| <= margin, midpoint anywhere) cross any disc image?
    bool cuts(const Vec3d& p, const Vec3d& q) const
    {
        return visit(p, q, [](int, const Vec3d&) { return true; });
    }

    // Every disc image crossing segment pq: (disc, image centre in pq's frame).
    std::vector<std::pair<int, Vec3d>> cutters(const Vec3d& p, const Vec3d& q) const
    {
        std::vector<std::pair<int, Vec3d>> out;
        visit(p, q, [&](int d, const Vec3d& c) { out.emplace_back(d, c); return false; });
        return out;
    }

private:
    // Calls f(disc, image centre in pq's frame) for each disc image crossing pq, in bucket
    // order, until f returns true; returns whether it did.
    template<typename F>
    bool visit(const Vec3d& p, const Vec3d& q, F&& f) const
    {
        const Vec3d m = (p + q) * 0.5;
        Vec3d shift;
        int idx[3];
        for (int a = 0; a < 3; ++a) {
            const double w = std::floor(m[a] / mSize);
            shift[a] = w * mSize;
            idx[a] = std::min(mN - 1, std::max(0, int((m[a] - shift[a]) / mCell)));
        }
        for (const auto& e : mCells[(size_t(idx[0]) * mN + idx[1]) * mN + idx[2]]) {
            const Disc& D = mDiscs[size_t(e.disc)];
            if (crosses(p, q, e.center + shift, D.normal, D.radius) && f(e.disc, e.center + shift)) {
                return true;
            }
        }
        return false;
    }

    struct Entry { int disc; Vec3d center; };
    const std::vector<Disc>& mDiscs;
    double mSize, mCell;
    int mN;
    std::vector<std::vector<Entry>> mCells;
};

struct Adjacent { int to; Vec3d step; }; // step: unwrapped vector from this point to `to`

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

std::array<float, 3> f3(const Vec3d& v) { return {float(v[0]), float(v[1]), float(v[2])}; }

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

// ---- filling the tile up to the fractures --------------------------------------------------
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

// A graph neighbour of a cluster point that lies in another cluster, in the cluster's
// unwrapped frame: its cluster (-1: an authored block or a dropped cluster) and the offset
// from that cluster's frame to this one, with the disc image that cut the edge (or -1).
struct Foreign
{
    Vec3d q;
    int cluster;
    Vec3d offset;
    int disc;
    Vec3d centre;
};

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

// The clusters' points (home frames), with what pair planes read of them before any block
// grows: their hull vertices (the support of every projection; the points themselves for
// the paper's point and segment primitives) and hull face normals.
struct ClusterSet
{
    std::vector<std::vector<Vec3d>> points, support, normals;
};

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

// A neighbouring cluster (image) whose pair plane waits for the overlap pass: no cutting disc
// separates the two, and a mid-gap plane would cut corners off both where they do not meet.
struct Deferred
{
    int cluster;
    Vec3d offset; ///< its frame → this cluster's
    std::vector<std::pair<int, Vec3d>> cut;
};

// Grow block b (cluster index c, from makeBlock, home frame of its points) to its fractures
// (steps 1 and 2 of the comment above); the pairs for step 3 go to @a deferred.

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

// An authored block's planes (normalised) and geometry; its vertices by plane triples.
Block makeAuthored(const AuthoredBlock& a, const std::vector<Vec3d>& inside)
{
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
void toHome(Block& b, double size)
{
    Vec3d shift;
    for (int a = 0; a < 3; ++a) shift[a] = -size * std::floor(double(b.anchors[0][size_t(a)]) / size);
    if (shift == Vec3d(0)) return;
    auto move = [&](std::array<float, 3>& v) {
        for (int a = 0; a < 3; ++a) v[size_t(a)] = float(double(v[size_t(a)]) + shift[a]);
    };
    for (auto& pl : b.planes) {
        pl[3] = float(double(pl[3]) + double(pl[0]) * shift[0] + double(pl[1]) * shift[1] +
                      double(pl[2]) * shift[2]);
    }
    move(b.a);
    move(b.b);
    for (auto& v : b.vertices) move(v);
    for (auto& v : b.cluster) move(v);
    for (auto& v : b.anchors) move(v);
    move(b.boundsMin);
    move(b.boundsMax);
}

} // namespace

// ---- parameters ---------------------------------------------------------------------------

BlockType blockTypeFromString(const std::string& name)
{
    for (int t = 0; t < 6; ++t) {
        if (name == kTypeNames[t]) return BlockType(t);
    }
    fail<ValueError>("blocks: unknown type '", name,
                     "' (expected equidimensional, prismatic, polyhedral, rhombohedral, "
                     "tabular or columnar)");
}

const char* blockTypeName(BlockType type) { return kTypeNames[int(type)]; }

// Defaults, scaled by the tile size s (the paper uses s ≈ 20 m; Table 1 for the counts):
//   points: Poisson radius 0.034·s ≈ 0.68 m → ≈ 14 600 points (Table 1: 14 524–14 589; the
//           paper's "r ≈ 10 cm" cannot give that count in a 20 m cube); edges up to 2r.
//   Set-based types place each set's discs evenly spaced along its normal (§3).
//   equidimensional 15 discs (5 per set), radii 0.5–0.7·s, jitter 1°, 10% irregular. The
//           paper's ≈ 5 m radii leave most fractures partial: the visibility splits then
//           extend them by whole planes and leave thin slivers (measured median min/max
//           extent 0.35); near-full discs give the near-cubic blocks the type is named for
//           (0.55). Jitter stays small: a large disc tilted by θ meets its periodic images
//           s·tan θ apart, and the gap between the two sheets becomes a sliver block;
//   prismatic 18 discs, radii 0.2–0.3·s, jitter 8°, 25% irregular ("slightly more
//           irregular");
//   polyhedral 44 discs, centres 0.05·s apart (≈ 1 m), radii 0.1–0.25·s, random normals;
//   rhombohedral 24 discs, radii 0.3–0.45·s, jitter 2°, three sets at 60° to each other;
//   tabular 30 discs: a third bedding planes (radius s), the rest radius ≈ s/10;
//   columnar 24 discs: radii 0.5–0.7·s along three sets 60° apart, 15% cross-joints.
void TileParams::resolveDefaults()
{
    const double s = tileSize;
    if (pointRadius <= 0) pointRadius = 0.034 * s;
    if (neighbourRadius <= 0) neighbourRadius = 2.0 * pointRadius;
    struct D { int count; double spacing, rmin, rmax, jitter, irregular; };
    const D defaults[6] = {
        {15, 0.10, 0.50, 0.70, 1, 0.10},  // equidimensional
        {18, 0.10, 0.20, 0.30, 8, 0.25},  // prismatic
        {44, 0.05, 0.05, 0.15, 0, 1.00},  // polyhedral
        {24, 0.10, 0.12, 0.22, 2, 0.10},  // rhombohedral
        {30, 0.10, 0.08, 0.12, 5, 0.00},  // tabular (small discs; beds have radius s)
        {18, 0.08, 0.50, 0.70, 3, 0.15},  // columnar
    };
    const D& d = defaults[int(type)];
    if (discCount < 0) discCount = d.count;
    if (discSpacing <= 0) discSpacing = d.spacing * s;
    if (discRadiusMin <= 0) discRadiusMin = d.rmin * s;
    if (discRadiusMax <= 0) discRadiusMax = std::max(discRadiusMin, d.rmax * s);
    if (jitterDeg < 0) jitterDeg = d.jitter;
    if (irregularFraction < 0) irregularFraction = d.irregular;
    if (fractureWidth < 0) fractureWidth = 0.002 * s;
}

void TileParams::validate() const
{
    const char* op = "blocks";
    require(std::isfinite(tileSize) && tileSize > 0 && tileSize <= 1e4, op, "tile size",
            "in (0, 10000] m", tileSize);
    require(std::isfinite(pointRadius) && pointRadius > 0 && pointRadius < tileSize / 2, op,
            "point radius", "in (0, tile size / 2)", pointRadius);
    require(tileSize / pointRadius <= 400, op, "tile size / point radius", "<= 400",
            tileSize / pointRadius);
    require(std::isfinite(neighbourRadius) && neighbourRadius > pointRadius &&
                neighbourRadius < tileSize / 2,
            op, "neighbour radius", "in (point radius, tile size / 2)", neighbourRadius);
    require(discCount >= 0 && discCount <= 10000, op, "disc count", "in [0, 10000]", discCount);
    require(std::isfinite(discSpacing) && discSpacing >= 0 && discSpacing < tileSize / 2, op,
            "disc spacing", "in [0, tile size / 2)", discSpacing);
    require(std::isfinite(discRadiusMin) && discRadiusMin > 0, op, "disc radius (min)", "> 0",
            discRadiusMin);
    require(std::isfinite(discRadiusMax) && discRadiusMax >= discRadiusMin &&
                discRadiusMax <= 4 * tileSize,
            op, "disc radius (max)", "in [min, 4 · tile size]", discRadiusMax);
    require(std::isfinite(jitterDeg) && jitterDeg >= 0 && jitterDeg <= 90, op, "jitter",
            "in [0, 90] degrees", jitterDeg);
    require(std::isfinite(irregularFraction) && irregularFraction >= 0 && irregularFraction <= 1,
            op, "irregular fraction", "in [0, 1]", irregularFraction);
    require(finite3(axis) && axis.length() > 1e-9, op, "axis", "a non-zero vector",
            std::to_string(axis[0]) + "," + std::to_string(axis[1]) + "," + std::to_string(axis[2]));
    require(std::isfinite(obliqueDeg) && obliqueDeg >= 30 && obliqueDeg <= 90, op,
            "oblique angle", "in [30, 90] degrees", obliqueDeg);
    require(minPoints >= 1 && minPoints <= 100000, op, "min points", "in [1, 100000]", minPoints);
    require(std::isfinite(fractureWidth) && fractureWidth >= 0 && fractureWidth < pointRadius, op,
            "fracture width", "in [0, point radius) m", fractureWidth);
    require(std::isfinite(smoothRadius) && smoothRadius >= 0 && smoothRadius < tileSize / 4, op,
            "smooth radius", "in [0, tile size / 4)", smoothRadius);
    require(std::isfinite(relief.amplitude) && relief.amplitude >= 0 &&
                relief.amplitude <= tileSize / 20,
            op, "warp amplitude", "in [0, tile size / 20]", relief.amplitude);
    require(std::isfinite(relief.scale) && relief.scale > 0 && relief.scale <= 1e4, op,
            "relief scale", "in (0, 10000] m", relief.scale);
    require(relief.octaves >= 1 && relief.octaves <= 12, op, "relief octaves", "in [1, 12]",
            relief.octaves);
    require(std::isfinite(relief.sharpness) && relief.sharpness >= 1 && relief.sharpness <= 64,
            op, "relief sharpness", "in [1, 64]", relief.sharpness);
    for (size_t i = 0; i < extraDiscs.size(); ++i) {
        const Disc& d = extraDiscs[i];
        const std::string what = "fracture " + std::to_string(i);
        require(finite3(d.center), op, (what + " centre").c_str(), "finite", "non-finite");
        require(finite3(d.normal) && d.normal.length() > 1e-9, op, (what + " normal").c_str(),
                "a non-zero vector", "zero");
        require(std::isfinite(d.radius) && d.radius > 0 && d.radius <= 4 * tileSize, op,
                (what + " radius").c_str(), "in (0, 4 · tile size]", d.radius);
    }
    for (size_t i = 0; i < authored.size(); ++i) {
        const std::string what = "authored block " + std::to_string(i);
        require(authored[i].planes.size() >= 4, op, what.c_str(), "at least 4 planes",
                authored[i].planes.size());
        for (const auto& q : authored[i].planes) {
            require(std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]) &&
                        std::isfinite(q[3]) && std::hypot(q[0], q[1], q[2]) > 1e-9,
                    op, (what + " plane").c_str(), "finite with a non-zero normal", "bad plane");
        }
    }
}

namespace {

std::array<double, 3> arr(const Vec3d& v) { return {v[0], v[1], v[2]}; }

// The double nearest the shortest decimal that reads back as the same float: the file
// prints ~9 digits per number instead of 17 and round-trips bit-exactly.
double shortFloat(float v)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", double(v));
    return std::strtod(buf, nullptr);
}

json floats(const std::array<float, 3>& v)
{
    return {shortFloat(v[0]), shortFloat(v[1]), shortFloat(v[2])};
}

Vec3d vecFrom(const json& j, const std::string& key)
{
    if (!j.is_array() || j.size() != 3) {
        fail<ValueError>("blocks: ", key, " must be an array of 3 numbers");
    }
    Vec3d v;
    for (int a = 0; a < 3; ++a) {
        if (!j[size_t(a)].is_number()) fail<ValueError>("blocks: ", key, " must hold numbers");
        v[a] = j[size_t(a)].get<double>();
    }
    return v;
}

double numFrom(const json& j, const std::string& key)
{
    if (!j.is_number()) fail<ValueError>("blocks: ", key, " must be a number");
    return j.get<double>();
}

void allowKeys(const json& j, const std::string& where, std::initializer_list<const char*> keys)
{
    if (!j.is_object()) fail<ValueError>("blocks: ", where, " must be an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
        bool ok = false;
        for (const char* k : keys) ok = ok || it.key() == k;
        if (!ok) fail<ValueError>("blocks: unknown key '", it.key(), "' in ", where);
    }
}

} // namespace

std::vector<Disc> fracturesFromJson(const json& j)
{
    if (!j.is_array()) fail<ValueError>("blocks: fractures must be an array of discs");
    std::vector<Disc> out;
    for (size_t i = 0; i < j.size(); ++i) {
        const std::string w = "fractures[" + std::to_string(i) + "]";
        allowKeys(j[i], w, {"center", "normal", "radius"});
        for (const char* k : {"center", "normal", "radius"}) {
            if (!j[i].contains(k)) fail<ValueError>("blocks: ", w, " needs \"", k, "\"");
        }
        out.push_back({vecFrom(j[i]["center"], w + ".center"), vecFrom(j[i]["normal"], w + ".normal"),
                       numFrom(j[i]["radius"], w + ".radius")});
    }
    return out;
}

AuthoredBlock authoredFromJson(const json& j, const std::string& w)
{
    if (!j.is_object() || !j.contains("type") || !j["type"].is_string()) {
        fail<ValueError>("blocks: ", w, " needs a \"type\" (box or polytope)");
    }
    AuthoredBlock a;
    const std::string type = j["type"];
    if (type == "box") {
        allowKeys(j, w, {"type", "center", "size", "rotate"});
        if (!j.contains("size")) fail<ValueError>("blocks: ", w, " needs \"size\"");
        const Vec3d c = j.contains("center") ? vecFrom(j["center"], w + ".center") : Vec3d(0);
        const Vec3d size = vecFrom(j["size"], w + ".size");
        for (int k = 0; k < 3; ++k) {
            if (!(size[k] > 0)) fail<ValueError>("blocks: ", w, ".size must be positive");
        }
        const Vec3d rot = j.contains("rotate") ? vecFrom(j["rotate"], w + ".rotate") : Vec3d(0);
        openvdb::math::Mat3d R = openvdb::math::rotation<openvdb::math::Mat3d>(
                                     openvdb::math::X_AXIS, rot[0] * M_PI / 180) *
                                 openvdb::math::rotation<openvdb::math::Mat3d>(
                                     openvdb::math::Y_AXIS, rot[1] * M_PI / 180) *
                                 openvdb::math::rotation<openvdb::math::Mat3d>(
                                     openvdb::math::Z_AXIS, rot[2] * M_PI / 180);
        for (int axisIdx = 0; axisIdx < 3; ++axisIdx) {
            for (double sgn : {1.0, -1.0}) {
                Vec3d e(0);
                e[axisIdx] = sgn;
                const Vec3d n = R.transform(e);
                a.planes.push_back({n[0], n[1], n[2], n.dot(c) + 0.5 * size[axisIdx]});
            }
        }
    } else if (type == "polytope") {
        allowKeys(j, w, {"type", "planes"});
        if (!j.contains("planes") || !j["planes"].is_array()) {
            fail<ValueError>("blocks: ", w, " needs \"planes\": [[nx, ny, nz, d], ...]");
        }
        for (const auto& q : j["planes"]) {
            if (!q.is_array() || q.size() != 4) {
                fail<ValueError>("blocks: ", w, ".planes entries must be [nx, ny, nz, d]");
            }
            std::array<double, 4> pl;
            for (size_t k = 0; k < 4; ++k) pl[k] = numFrom(q[k], w + ".planes");
            a.planes.push_back(pl);
        }
    } else {
        fail<ValueError>("blocks: ", w, " has unknown type '", type, "' (box or polytope)");
    }
    return a;
}

std::vector<AuthoredBlock> authoredListFromJson(const json& j)
{
    if (!j.is_array()) fail<ValueError>("blocks: authored must be an array");
    std::vector<AuthoredBlock> out;
    for (size_t i = 0; i < j.size(); ++i) {
        out.push_back(authoredFromJson(j[i], "authored[" + std::to_string(i) + "]"));
    }
    return out;
}

json TileStats::toJson() const
{
    return {{"points", points},           {"edges", edges},
            {"cut_edges", cutEdges},      {"discs", discs},
            {"blocks", blocks},           {"dropped_clusters", droppedClusters},
            {"dropped_points", droppedPoints}, {"visibility_splits", visibilitySplits},
            {"wrap_cuts", wrapCuts},      {"merged_clusters", mergedClusters},
            {"small_blocks", smallBlocks},
            {"mean_points", meanPoints}};
    // No timings: a tile file (and the rockvdb:tile metadata) is a pure function of the
    // parameters, so the same call writes the same bits; times go to stderr and bench/.
}

// ---- generation ---------------------------------------------------------------------------

BlockTile generateTile(const TileParams& in)
{
    Task task;
    return generateTile(in, task);
}

BlockTile generateTile(const TileParams& in, Task& task)
{
    TileParams p = in;
    p.resolveDefaults();
    p.validate();
    p.axis = p.axis.unit();
    const double s = p.tileSize;
    BlockTile tile;
    tile.params = p;
    TileStats& st = tile.stats;
    const auto tStart = Clock::now();

    // 1. Poisson-sphere points in the periodic tile.
    auto t0 = Clock::now();
    const std::vector<Vec3d> pts = poissonPeriodic(s, p.pointRadius, p.seed, kPoints);
    st.points = pts.size();
    st.sampling = since(t0);

    // Authored blocks claim the points inside them (their own image nearest each point).
    std::vector<int> owner(pts.size(), -1);
    std::vector<std::vector<Vec3d>> authoredPts(p.authored.size());
    for (size_t i = 0; i < pts.size(); ++i) {
        for (size_t a = 0; a < p.authored.size(); ++a) {
            Vec3d u;
            if (insideAuthored(p.authored[a], pts[i], s, u)) {
                owner[i] = int(a);
                authoredPts[a].push_back(u);
                break;
            }
        }
    }

    task.check();
    // 2. Neighbour graph (periodic).
    t0 = Clock::now();
    const std::vector<PeriodicEdge> edges = neighbourGraph(pts, s, p.neighbourRadius);
    st.edges = edges.size();
    st.graph = since(t0);

    task.check();
    // 3. Fractures cut the edges; authored blocks are cut out of the graph.
    t0 = Clock::now();
    tile.discs = makeDiscs(p);
    st.discs = tile.discs.size();
    const DiscGrid discGrid(tile.discs, s, p.neighbourRadius);
    std::vector<std::vector<Adjacent>> adj(pts.size());
    // With fill: the cut edges, both ways, with each disc image across them (relative to the
    // point; disc -1 for edges into authored blocks).
    struct Cut { int to; Vec3d step; int disc; Vec3d centre; };
    std::vector<std::vector<Cut>> cuts(p.fill ? pts.size() : 0);
    for (const auto& e : edges) {
        const Vec3d pa = pts[size_t(e.a)];
        const Vec3d pb = pts[size_t(e.b)] + Vec3d(e.shift[0], e.shift[1], e.shift[2]) * s;
        // With fill, every disc across a cut edge is kept: any of them may be the fracture
        // between the two clusters (one pass over the discs either way).
        const bool authored = owner[size_t(e.a)] >= 0 || owner[size_t(e.b)] >= 0;
        std::vector<std::pair<int, Vec3d>> across;
        if (p.fill && !authored) across = discGrid.cutters(pa, pb);
        const bool cut = authored || (p.fill ? !across.empty() : discGrid.cuts(pa, pb));
        if (cut) {
            ++st.cutEdges;
            if (p.fill) {
                if (across.empty()) across.emplace_back(-1, Vec3d(0));
                for (const auto& [d, c] : across) {
                    cuts[size_t(e.a)].push_back({e.b, pb - pa, d, c - pa});
                    cuts[size_t(e.b)].push_back({e.a, pa - pb, d, c - pb});
                }
            }
            continue;
        }
        adj[size_t(e.a)].push_back({e.b, pb - pa});
        adj[size_t(e.b)].push_back({e.a, pa - pb});
    }
    st.fracturing = since(t0);
    task.check();

    // 4. Clusters: connected components, unwrapped; wrapping clusters are cut opposite
    //    their first point; then split until no disc separates two of their points.
    t0 = Clock::now();
    std::vector<int> label(pts.size(), -1);
    int nextLabel = 0;
    std::vector<int> free;
    for (size_t i = 0; i < pts.size(); ++i) if (owner[i] < 0) free.push_back(int(i));
    std::deque<std::vector<int>> queue;
    for (auto& c : components(free, adj, label, nextLabel)) queue.push_back(std::move(c));
    std::vector<std::vector<Vec3d>> clusters;
    std::vector<std::vector<int>> members; // the clusters' point indices, as in clusters
    std::vector<std::vector<int>> small;   // with fill: clusters under min points, to merge
    std::vector<std::vector<Vec3d>> smallP;
    std::vector<Vec3d> pos(pts.size());
    std::vector<int> stamp(pts.size(), -1);
    int visit = 0;
    while (!queue.empty()) {
        std::vector<int> comp = std::move(queue.front());
        queue.pop_front();
        const int lab = label[size_t(comp[0])];
        int axis = -1;
        if (!unwrap(comp, pts, adj, label, lab, s, pos, stamp, visit++, axis)) {
            // Cut the loop around the torus with the plane half a tile from the first point.
            ++st.wrapCuts;
            const double cut = pts[size_t(comp[0])][axis] + 0.5 * s;
            std::vector<std::vector<Adjacent>>& A = adj;
            for (int m : comp) {
                auto& list = A[size_t(m)];
                list.erase(std::remove_if(list.begin(), list.end(), [&](const Adjacent& e) {
                    if (label[size_t(e.to)] != lab) return false;
                    const double a0 = pts[size_t(m)][axis], a1 = a0 + e.step[axis];
                    const double k0 = std::floor((a0 - cut) / s), k1 = std::floor((a1 - cut) / s);
                    return k0 != k1;
                }), list.end());
            }
            for (auto& c : components(comp, adj, label, nextLabel)) queue.push_back(std::move(c));
            continue;
        }
        std::vector<Vec3d> P;
        P.reserve(comp.size());
        for (int m : comp) P.push_back(pos[size_t(m)]);
        Vec3d centre;
        const int d = separatingDisc(P, tile.discs, s, centre);
        if (d >= 0) {
            // Visibility (§4.1): the fracture continues across this cluster — split it by
            // the disc's plane, then into connected parts.
            ++st.visibilitySplits;
            const Vec3d& n = tile.discs[size_t(d)].normal;
            std::vector<int> side[2];
            for (size_t m = 0; m < comp.size(); ++m) side[n.dot(P[m] - centre) >= 0].push_back(comp[m]);
            for (auto& part : side) {
                for (auto& c : components(part, adj, label, nextLabel)) queue.push_back(std::move(c));
            }
            continue;
        }
        if (int(comp.size()) < p.minPoints) {
            if (p.fill) {
                small.push_back(std::move(comp));
                smallP.push_back(std::move(P));
            } else {
                ++st.droppedClusters;
                st.droppedPoints += comp.size();
            }
            continue;
        }
        clusters.push_back(std::move(P));
        members.push_back(std::move(comp));
    }
    // With fill, a cluster under min points (a sliver between a fracture and its neighbour's
    // end, a corner cut off by two discs) joins a neighbour, so it neither leaves a void nor
    // becomes a block of its own that the smooth intersection would erode away (and Table 1's
    // counts stay the paper's): the neighbour it shares the most graph edges with whose
    // joint hull holds no point of a third cluster (a joint hull wrapped round another
    // cluster could not be separated from it by a plane, and its points would fall in the
    // fracture). A small cluster that no neighbour can take stays a block.
    std::vector<int> clusterOf(p.fill ? pts.size() : 0, -1);
    std::vector<int> indexIn(p.fill ? pts.size() : 0, -1); // position within its cluster
    std::vector<int> smallOf(p.fill ? pts.size() : 0, -1);
    auto enrol = [&](size_t c) {
        for (size_t i = 0; i < members[c].size(); ++i) {
            clusterOf[size_t(members[c][i])] = int(c);
            indexIn[size_t(members[c][i])] = int(i);
            smallOf[size_t(members[c][i])] = -1;
        }
    };
    for (size_t c = 0; p.fill && c < clusters.size(); ++c) enrol(c);
    for (size_t k = 0; k < small.size(); ++k) {
        for (int m : small[k]) smallOf[size_t(m)] = int(k);
    }
    for (size_t k = 0; k < small.size(); ++k) {
        // Edges (cut or not) from the small cluster's points to each large cluster.
        std::map<int, std::pair<int, Vec3d>> votes; // cluster → (edges, this frame → its frame)
        for (size_t i = 0; i < small[k].size(); ++i) {
            const int m = small[k][i];
            auto vote = [&](int to, const Vec3d& step) {
                const int c = clusterOf[size_t(to)];
                if (c < 0) return;
                auto& v = votes[c];
                if (v.first++ == 0) {
                    v.second = clusters[size_t(c)][size_t(indexIn[size_t(to)])] - step - smallP[k][i];
                }
            };
            for (const auto& e : cuts[size_t(m)]) vote(e.to, e.step);
            for (const auto& e : adj[size_t(m)]) vote(e.to, e.step);
        }
        std::vector<std::tuple<int, int, Vec3d>> candidates; // (−edges, cluster, shift)
        for (const auto& [c, v] : votes) candidates.emplace_back(-v.first, c, v.second);
        std::sort(candidates.begin(), candidates.end(), [](const auto& x, const auto& y) {
            return std::make_pair(std::get<0>(x), std::get<1>(x)) < std::make_pair(std::get<0>(y), std::get<1>(y));
        });
        int best = -1;
        Vec3d shift(0);
        for (const auto& [negEdges, c, sh] : candidates) {
            std::vector<Vec3d> joint = clusters[size_t(c)];
            for (const auto& q : smallP[k]) joint.push_back(q + sh);
            const Hull hull = convexHull(joint, 1e-6 * std::max(1.0, p.pointRadius));
            bool clean = true;
            if (hull.dimension == 3) {
                // Any other cluster's point, an authored block's included.
                auto third = [&](int to) {
                    return clusterOf[size_t(to)] != c && smallOf[size_t(to)] != int(k);
                };
                auto inside = [&](const Vec3d& q) {
                    for (const auto& h : hull.planes) {
                        if (h[0] * q[0] + h[1] * q[1] + h[2] * q[2] - h[3] > -1e-6) return false;
                    }
                    return true;
                };
                const std::vector<int>& mem = members[size_t(c)];
                for (size_t i = 0; i < joint.size() && clean; ++i) {
                    const int m = i < mem.size() ? mem[i] : small[k][i - mem.size()];
                    for (const auto& e : cuts[size_t(m)]) {
                        if (third(e.to) && inside(joint[i] + e.step)) { clean = false; break; }
                    }
                    for (const auto& e : adj[size_t(m)]) {
                        if (!clean) break;
                        if (third(e.to) && inside(joint[i] + e.step)) clean = false;
                    }
                }
            }
            if (clean) {
                best = c;
                shift = sh;
                break;
            }
        }
        if (best < 0) {
            ++st.smallBlocks;
            clusters.push_back(std::move(smallP[k]));
            members.push_back(std::move(small[k]));
            enrol(clusters.size() - 1);
            continue;
        }
        ++st.mergedClusters;
        for (size_t i = 0; i < small[k].size(); ++i) {
            clusters[size_t(best)].push_back(smallP[k][i] + shift);
            members[size_t(best)].push_back(small[k][i]);
        }
        enrol(size_t(best));
    }
    st.clustering = since(t0);
    task.check();

    // 5. Convex bases (CGAL hulls); ids: authored blocks first, then clusters in order of
    //    their smallest point (the queue order above is deterministic).
    t0 = Clock::now();
    for (size_t a = 0; a < p.authored.size(); ++a) {
        tile.blocks.push_back(makeAuthored(p.authored[a], authoredPts[a]));
    }
    std::vector<Block> made(clusters.size());
    ClusterSet cs; // the hulls as made, before any block grows
    cs.support.resize(clusters.size());
    cs.normals.resize(clusters.size());
    for (size_t c = 0; c < clusters.size(); ++c) {
        made[c] = makeBlock(clusters[c], p.pointRadius, p.smoothRadius);
        for (const auto& q : made[c].planes) cs.normals[c].emplace_back(q[0], q[1], q[2]);
        for (const auto& v : made[c].vertices) cs.support[c].emplace_back(v[0], v[1], v[2]);
        if (cs.support[c].empty()) cs.support[c] = clusters[c];
    }
    cs.points = std::move(clusters);
    const std::vector<std::vector<Vec3d>>& pointsOf = cs.points;
    // Blocks grow at most `cap` past their points.
    const double cap = p.neighbourRadius;
    std::vector<std::vector<Deferred>> deferredOf(made.size());
    // Each block grows on its own (TBB; its planes depend only on the hulls as made).
    if (p.fill) tbb::parallel_for(size_t(0), made.size(), [&](size_t c) {
        // Foreign neighbours: across cut edges, and uncut edges to points that visibility
        // splits or wrap cuts put in another cluster.
        std::vector<Foreign> foreign;
        const std::vector<int>& mem = members[c];
        auto add = [&](const Vec3d& q, int to, int disc, const Vec3d& centre) {
            const int k = clusterOf[size_t(to)];
            const Vec3d off = k >= 0 ? q - pointsOf[size_t(k)][size_t(indexIn[size_t(to)])] : Vec3d(0);
            foreign.push_back({q, k, off, disc, centre});
        };
        for (size_t i = 0; i < mem.size(); ++i) {
            const Vec3d& at = pointsOf[c][i];
            for (const auto& e : cuts[size_t(mem[i])]) add(at + e.step, e.to, e.disc, at + e.centre);
            for (const auto& e : adj[size_t(mem[i])]) {
                if (clusterOf[size_t(e.to)] != int(c)) add(at + e.step, e.to, -1, Vec3d(0));
            }
        }
        growToFractures(made[c], int(c), cs, foreign, tile.discs, p.fractureWidth, cap,
                        deferredOf[c]);
    });
    // Grown blocks that still meet (neighbours across no separating disc, clusters that are
    // not graph neighbours reaching into one corner) get their pair's separating plane, both
    // sides mirrored; rounds repeat while new planes change what meets. The pairs are found
    // in parallel (per lower block) and applied in block order.
    struct Split { size_t k; std::array<double, 4> mine, theirs; };
    task.check();
    for (int round = 0; p.fill && round < 4; ++round) {
        task.check();
        std::vector<std::vector<std::pair<int, int>>> edges(made.size());
        tbb::parallel_for(size_t(0), made.size(), [&](size_t c) { edges[c] = edgesOf(made[c]); });
        std::vector<std::vector<Split>> splits(made.size());
        tbb::parallel_for(size_t(0), made.size(), [&](size_t c) {
            const Block& A = made[c];
            for (size_t k = c; k < made.size(); ++k) {
                const Block& B = made[k];
                for (int i = -1; i <= 1; ++i)
                    for (int j = -1; j <= 1; ++j)
                        for (int l = -1; l <= 1; ++l) {
                            // A block and its own images too (k == c, a shift).
                            if (k == c && std::make_tuple(i, j, l) <= std::make_tuple(0, 0, 0)) continue;
                            const Vec3d off = Vec3d(i, j, l) * s; // k's frame → c's
                            bool near = true;
                            for (int a = 0; a < 3 && near; ++a) {
                                near = B.boundsMin[size_t(a)] + off[a] < A.boundsMax[size_t(a)] &&
                                       A.boundsMin[size_t(a)] < B.boundsMax[size_t(a)] + off[a];
                            }
                            if (!near || !meets(A, edges[c], B, edges[k], off, 1e-6)) continue;
                            // The discs across their edges, if they are graph neighbours.
                            const std::vector<std::pair<int, Vec3d>>* cut = nullptr;
                            for (const auto& d : deferredOf[c]) {
                                if (d.cluster == int(k) && (d.offset - off).length() < 1e-3) cut = &d.cut;
                            }
                            static const std::vector<std::pair<int, Vec3d>> none;
                            Vec3d n;
                            double m;
                            if (!pairPlane(cs, int(c), int(k), off, cut ? *cut : none, tile.discs,
                                           false, n, m)) continue;
                            // c's plane n·x <= m − w/2; in k's frame (x_c = x_k + off) k keeps
                            // −n·x_k <= n·off − m − w/2.
                            const double hw = 0.5 * p.fractureWidth;
                            splits[c].push_back({k, {n[0], n[1], n[2], m - hw},
                                                 {-n[0], -n[1], -n[2], n.dot(off) - m - hw}});
                        }
            }
        });
        std::vector<std::vector<std::array<double, 4>>> extra(made.size());
        size_t added = 0;
        for (size_t c = 0; c < made.size(); ++c) {
            for (const auto& sp : splits[c]) {
                extra[c].push_back(sp.mine);
                extra[sp.k].push_back(sp.theirs);
                ++added;
            }
        }
        if (added == 0) break;
        tbb::parallel_for(size_t(0), made.size(), [&](size_t c) {
            if (extra[c].empty()) return;
            std::vector<std::array<double, 4>> all = extra[c];
            for (const auto& q : made[c].planes) all.push_back({q[0], q[1], q[2], q[3]});
            setPolytope(made[c], all, pointsOf[c]);
        });
    }
    std::vector<size_t> order(made.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        const auto& x = made[a].anchors[0];
        const auto& y = made[b].anchors[0];
        return std::tie(x[2], x[1], x[0]) < std::tie(y[2], y[1], y[0]);
    });
    for (size_t k : order) tile.blocks.push_back(std::move(made[k]));
    for (auto& b : tile.blocks) toHome(b, s);
    st.hulls = since(t0);
    st.generation = since(tStart);
    st.blocks = tile.blocks.size();
    size_t sum = 0;
    for (const auto& b : tile.blocks) sum += size_t(b.points);
    st.meanPoints = tile.blocks.empty() ? 0.0 : double(sum) / double(tile.blocks.size());
    return tile;
}

// ---- the tile file ------------------------------------------------------------------------

json tileToJson(const BlockTile& t)
{
    json j;
    j["format"] = "rockvdb-tile";
    j["version"] = 1;
    j["generator"] = std::string("rockvdb ") + version();
    j["params"] = t.params.toJson();
    json discs = json::array();
    for (const auto& d : t.discs) {
        discs.push_back({arr(d.center)[0], arr(d.center)[1], arr(d.center)[2], d.normal[0],
                         d.normal[1], d.normal[2], d.radius});
    }
    j["discs"] = discs;
    json blocks = json::array();
    for (const auto& b : t.blocks) {
        json jb;
        jb["kind"] = b.kind == BlockKind::Polytope ? "polytope"
                   : b.kind == BlockKind::Segment  ? "segment" : "point";
        if (b.kind == BlockKind::Polytope) {
            json planes = json::array();
            for (const auto& q : b.planes) {
                planes.push_back({shortFloat(q[0]), shortFloat(q[1]), shortFloat(q[2]),
                                  shortFloat(q[3])});
            }
            jb["planes"] = planes;
        } else {
            jb["a"] = floats(b.a);
            jb["b"] = floats(b.b);
            jb["radius"] = shortFloat(b.radius);
        }
        json anchors = json::array();
        for (const auto& a : b.anchors) anchors.push_back(floats(a));
        jb["anchors"] = anchors;
        jb["bounds"] = {floats(b.boundsMin), floats(b.boundsMax)};
        jb["points"] = b.points;
        if (b.authored) jb["authored"] = true;
        blocks.push_back(std::move(jb));
    }
    j["blocks"] = blocks;
    j["stats"] = t.stats.toJson();
    return j;
}

namespace {

std::array<float, 3> f3From(const json& j)
{
    if (!j.is_array() || j.size() != 3) fail<ValueError>("tile file: expected [x, y, z]");
    return {j[0].get<float>(), j[1].get<float>(), j[2].get<float>()};
}

} // namespace

BlockTile tileFromJson(const json& j)
{
    try {
        if (!j.is_object() || j.value("format", "") != "rockvdb-tile") {
            fail<ValueError>("tile file: not a rockvdb tile (format must be \"rockvdb-tile\")");
        }
        if (j.value("version", 0) != 1) {
            fail<ValueError>("tile file: unsupported version ", j.value("version", 0), " (expected 1)");
        }
        BlockTile t;
        t.params = TileParams::fromJson(j.at("params"));
        t.params.resolveDefaults();
        t.params.validate();
        for (const auto& d : j.at("discs")) {
            if (!d.is_array() || d.size() != 7) fail<ValueError>("tile file: bad disc entry");
            t.discs.push_back({Vec3d(d[0].get<double>(), d[1].get<double>(), d[2].get<double>()),
                               Vec3d(d[3].get<double>(), d[4].get<double>(), d[5].get<double>()),
                               d[6].get<double>()});
        }
        for (const auto& jb : j.at("blocks")) {
            Block b;
            const std::string kind = jb.at("kind");
            if (kind == "polytope") {
                b.kind = BlockKind::Polytope;
                for (const auto& q : jb.at("planes")) {
                    if (!q.is_array() || q.size() != 4) fail<ValueError>("tile file: bad plane");
                    b.planes.push_back({q[0].get<float>(), q[1].get<float>(), q[2].get<float>(),
                                        q[3].get<float>()});
                }
                if (b.planes.empty()) fail<ValueError>("tile file: a polytope block has no planes");
            } else if (kind == "segment" || kind == "point") {
                b.kind = kind == "segment" ? BlockKind::Segment : BlockKind::Point;
                b.a = f3From(jb.at("a"));
                b.b = f3From(jb.at("b"));
                b.radius = jb.at("radius").get<float>();
                if (!(b.radius > 0)) fail<ValueError>("tile file: block radius must be > 0");
            } else {
                fail<ValueError>("tile file: unknown block kind '", kind, "'");
            }
            for (const auto& v : jb.at("anchors")) b.anchors.push_back(f3From(v));
            if (b.anchors.empty()) fail<ValueError>("tile file: a block has no anchors");
            b.boundsMin = f3From(jb.at("bounds").at(0));
            b.boundsMax = f3From(jb.at("bounds").at(1));
            b.points = jb.value("points", 0);
            b.authored = jb.value("authored", false);
            t.blocks.push_back(std::move(b));
        }
        if (j.contains("stats")) {
            const json& s = j["stats"];
            t.stats.points = s.value("points", size_t(0));
            t.stats.discs = s.value("discs", size_t(0));
            t.stats.blocks = s.value("blocks", size_t(0));
            t.stats.meanPoints = s.value("mean_points", 0.0);
        }
        return t;
    } catch (const json::exception& e) {
        fail<ValueError>("tile file: malformed (", e.what(), ")");
    }
}

void writeTile(const BlockTile& tile, const std::string& path)
{
    writeFileAtomic(path, tileToJson(tile).dump() + "\n");
}

BlockTile readTile(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in) fail<IoError>("tile file: cannot open '", path, "'");
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string bytes = ss.str();
    json j;
    // A vdb_blocks .vdb carries the tile as metadata "rockvdb:tile" on grid "surface".
    if (bytes.size() >= 4 && bytes.compare(0, 4, std::string(" BDV", 4)) == 0) {
        std::string text;
        try {
            openvdb::io::File file(path);
            file.open(false);
            const openvdb::GridPtrVecPtr grids = file.readAllGridMetadata();
            file.close();
            for (const auto& g : *grids) {
                if (auto m = g->getMetadata<openvdb::StringMetadata>("rockvdb:tile")) {
                    text = m->value();
                    break;
                }
            }
        } catch (const openvdb::Exception& e) {
            fail<IoError>("tile file: cannot read '", path, "' (", e.what(), ")");
        }
        if (text.empty()) {
            fail<ValueError>("tile file: '", path, "' is a .vdb without rockvdb:tile metadata "
                             "(write it with vdb_blocks)");
        }
        j = json::parse(text, nullptr, false);
    } else {
        j = json::parse(bytes, nullptr, false);
    }
    if (j.is_discarded()) {
        fail<ValueError>("tile file: '", path, "' is not JSON (expected a rockvdb tile)");
    }
    return tileFromJson(j);
}

} // namespace blocks
} // namespace rockvdb
