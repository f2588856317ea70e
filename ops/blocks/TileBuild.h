// SPDX-License-Identifier: Apache-2.0
// rockvdb — block tile generation, internals shared by its phases (not installed, not API):
//   Fractures.cc  the fracture discs per block type (§4.1) and their periodic images;
//   Clusters.cc   graph components, unwrapping, visibility splits, hull blocks (§4.2);
//   Fill.cc       blocks grown to their fractures (rockvdb's fill, see there);
//   BlockTile.cc  generateTile: the phases in order; BlockTileParams.cc, TileFile.cc: the
//                 parameters' defaults and checks, the tile file.
#pragma once

#include <rockvdb/blocks/BlockTile.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <utility>
#include <vector>

namespace rockvdb {
namespace blocks {
namespace tilegen {

/// The derived defaults of the tile's rows (BlockTileParams.cc says where each comes from):
/// Poisson radius, fracture width, rounding radius R and warp amplitude per metre of tile
/// size, and the per-type disc set.
constexpr double kPointRadiusPerSize = 0.034;
constexpr double kFractureWidthPerSize = 0.002;
constexpr double kSmoothRadiusPerSize = 0.0125;   // 0.25 m at the paper's 20 m
constexpr double kWarpAmplitudePerSize = 0.0025;  // 0.05 m at 20 m
struct TypeDefaults
{
    int count;
    double spacing, rmin, rmax; ///< fractions of the tile size
    double jitter, irregular;   ///< degrees, share
};
const TypeDefaults& typeDefaults(BlockType type);

/// @brief The rules between the tile's rows (each row's range is the table's), on derived
/// values: ValueError naming the row.
void checkTileRules(const BlockTileParams& p);

// Random streams (one per independent quantity, see core/Random.h).
enum Stream : uint64_t {
    kPoints = 1, kDiscCentres = 2, kDiscShape = 3, kBedding = 4, kAnchors = 5, kFrame = 6
};

using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t0)
{
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Orthonormal frame (e1, e2, u) around the unit axis u.
inline void frame(const Vec3d& u, Vec3d& e1, Vec3d& e2)
{
    const Vec3d helper = std::abs(u[0]) < 0.9 ? Vec3d(1, 0, 0) : Vec3d(0, 1, 0);
    e1 = helper.cross(u).unit();
    e2 = u.cross(e1);
}

// Uniform unit vector from two uniforms.
inline Vec3d unitVector(double a, double b)
{
    const double z = 2 * a - 1, phi = 2 * M_PI * b, s = std::sqrt(std::max(0.0, 1 - z * z));
    return Vec3d(s * std::cos(phi), s * std::sin(phi), z);
}

// Tilt n by an angle up to maxDeg about a random perpendicular axis.
inline Vec3d jitter(const Vec3d& n, double maxDeg, double a, double b)
{
    if (maxDeg <= 0) return n;
    Vec3d e1, e2;
    frame(n, e1, e2);
    const double angle = maxDeg * M_PI / 180.0 * std::sqrt(a), phi = 2 * M_PI * b;
    const Vec3d perp = e1 * std::cos(phi) + e2 * std::sin(phi);
    return (n * std::cos(angle) + perp * std::sin(angle)).unit();
}

inline bool finite3(const Vec3d& v)
{
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

inline std::array<float, 3> f3(const Vec3d& v) { return {float(v[0]), float(v[1]), float(v[2])}; }

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

// ---- fractures (Fractures.cc) ----

/// The type's fracture discs over one periodic tile [0, s)³ from p.seed; the set directions
/// from @a frameSeed (p.seed when negative), so tiles of one rock mass can share them.
std::vector<Disc> makeDiscs(const BlockTileParams& p, int64_t frameSeed = -1);

// ---- the phases after sampling (BlockTile.cc) ----

/// Steps 2–5 of generateTile on given points and discs in the periodic cube of side
/// p.tileSize (p resolved): graph, fractures, clusters, blocks. Blocks keep their cluster's
/// points (Block::cluster).
BlockTile buildTile(const BlockTileParams& p, const std::vector<Vec3d>& points, std::vector<Disc> discs,
                    Task& task);

// ---- clusters and their blocks (Clusters.cc) ----

struct Adjacent { int to; Vec3d step; }; // step: unwrapped vector from this point to `to`

// Connected components of `members` using adjacency restricted to `allowed` (by label).
std::vector<std::vector<int>> components(const std::vector<int>& members,
                                         const std::vector<std::vector<Adjacent>>& adj,
                                         std::vector<int>& label, int& nextLabel);

// Unwrap a cluster by breadth-first search from its first point into pos[] (indexed by
// point). Returns false when the cluster wraps around the torus (some point reached at two
// different images); then `axis` is a wrapping axis.
bool unwrap(const std::vector<int>& comp, const std::vector<Vec3d>& pts,
            const std::vector<std::vector<Adjacent>>& adj, const std::vector<int>& label,
            int lab, double size, std::vector<Vec3d>& pos, std::vector<int>& stamp, int visit,
            int& axis);

// The first disc image that separates two points of the cluster (visibility, §4.1), or -1.
// Only images whose plane cuts the cluster's box and whose disc meets it are examined; the
// points nearest the disc's axis on each side are paired first (a cluster spreading around
// a disc shows it there), then every pair.
int separatingDisc(const std::vector<Vec3d>& P, const std::vector<Disc>& discs, double size,
                   Vec3d& imageCentre);

// Anchors: the centroid, then farthest-point samples of the cluster (deterministic).
std::vector<std::array<float, 3>> anchorsOf(const std::vector<Vec3d>& P, const Vec3d& centroid,
                                            size_t count);

// Block geometry from a cluster (unwrapped points, home frame).
Block makeBlock(const std::vector<Vec3d>& P, double thickness, double smoothRadius);

// An authored block's planes (normalised) and geometry; its vertices by plane triples.
Block makeAuthored(const AuthoredBlock& a, const std::vector<Vec3d>& inside);

// Inside test of an authored block, for the periodic image nearest the point; returns the
// unwrapped position (or false).
bool insideAuthored(const AuthoredBlock& a, const Vec3d& p, double size, Vec3d& unwrapped);

// Move a block by @a shift (planes, ends, vertices, cluster, anchors, bounds; as floats).
void translate(Block& b, const Vec3d& shift);

// Move a block so its first anchor (the centroid) lies in [0, s)³.
void toHome(Block& b, double size);

// ---- filling the tile up to the fractures (Fill.cc) ----

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

// The clusters' points (home frames), with what pair planes read of them before any block
// grows: their hull vertices (the support of every projection; the points themselves for
// the paper's point and segment primitives) and hull face normals.
struct ClusterSet
{
    std::vector<std::vector<Vec3d>> points, support, normals;
};

// A neighbouring cluster (image) whose pair plane waits for the overlap pass: no cutting disc
// separates the two, and a mid-gap plane would cut corners off both where they do not meet.
struct Deferred
{
    int cluster;
    Vec3d offset; ///< its frame → this cluster's
    std::vector<std::pair<int, Vec3d>> cut;
};

// The plane separating clusters a and b (b's points moved by offset into a's frame), as
// (outward normal from a, position) in a's frame; computed from the lower index so both
// sides get the same plane. Candidates, in order: a cutting disc whose plane separates the
// two (the fracture itself); else the widest gap along a cutting disc's normal, a hull
// face normal of either cluster (a separating axis of two disjoint convex hulls is among
// them or their edges' cross products) or the search of separatingPlane, placed mid-gap.
bool pairPlane(const ClusterSet& cs, int a, int b, const Vec3d& offset,
               const std::vector<std::pair<int, Vec3d>>& cutDiscs,
               const std::vector<Disc>& discs, bool discOnly, Vec3d& n, double& m);

// A unit n and m with n·x < m < n·y for every x in X, y in Y (m mid-gap); false if the
// search does not find one. Deterministic for given X, Y.
bool separatingPlane(const std::vector<Vec3d>& X, const std::vector<Vec3d>& Y, Vec3d& n, double& m);

// b becomes the polytope of @a all, its vertices, facet areas and bounds from it; unchanged
// when the polytope is unbounded or holds neither the centroid of the cluster's points P nor
// any of them (a plane of a non-separable pair may leave the centroid outside: then the
// deepest point is the centre).
bool setPolytope(Block& b, const std::vector<std::array<double, 4>>& all,
                 const std::vector<Vec3d>& P);

// The edges of polytope b: vertex pairs on two common planes.
std::vector<std::pair<int, int>> edgesOf(const Block& b);

// Does polytope a meet polytope b moved by @a shift, deeper than @a tol? Exact for convex
// polytopes: their intersection's vertices are vertices of one inside the other or crossings
// of one's edges with the other's faces, so clipping every edge of each by the other's
// half-spaces (Cyrus–Beck) finds any overlap.
bool meets(const Block& a, const std::vector<std::pair<int, int>>& ea, const Block& b,
           const std::vector<std::pair<int, int>>& eb, const Vec3d& shift, double tol);

// Grow block b (cluster index c, from makeBlock, home frame of its points) to its fractures
// (steps 1 and 2 of Fill.cc's comment); the pairs for step 3 go to @a deferred.
void growToFractures(Block& b, int c, const ClusterSet& cs, const std::vector<Foreign>& F,
                     const std::vector<Disc>& discs, double w, double cap,
                     std::vector<Deferred>& deferred);

} // namespace tilegen
} // namespace blocks
} // namespace rockvdb
