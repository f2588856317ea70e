// SPDX-License-Identifier: Apache-2.0
// Aperiodic block tiles: regions of corner-coloured lattice features (see Aperiodic.h).
#include "Aperiodic.h"

#include <rockvdb/blocks/TileBuild.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/Sampling.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <set>

namespace rockvdb {
namespace blocks {

using namespace tilegen;

namespace {

// Cores and reaches in tile sizes (Aperiodic.h). Small cores keep the share of the blocks that
// only 2 or 4 colourings tell apart (vertex and edge regions) small.
constexpr double kA = 0.04, kB = 0.03, kC = 0.02;
constexpr double kReach[4] = {0.35, 0.35, 0.35, 0.0}; // by dimension
constexpr uint64_t kStreamColour = 0x41504552494f44ULL; // vertex colours
constexpr uint64_t kStreamRegion = 0x524547494f4eULL;   // region seeds
constexpr uint64_t kStreamIds = 0x494453ULL;            // id offsets
constexpr uint64_t kStreamOrigin = 0x4f524947ULL;       // the lattice's origin
constexpr size_t kIdSlot = 8192;                         // ids per region of a cube tile

int dimOf(int mask) { return (mask & 1) + ((mask >> 1) & 1) + ((mask >> 2) & 1); }

struct Feature
{
    int mask;
    std::array<int, 3> base;
    bool operator==(const Feature& o) const { return mask == o.mask && base == o.base; }
};

// The feature whose core holds q (tile units, world lattice).
Feature coreOf(const Vec3d& q)
{
    int n[3];
    double d[3];
    std::array<int, 3> fl;
    for (int a = 0; a < 3; ++a) {
        n[a] = int(std::floor(q[a] + 0.5));
        d[a] = std::abs(q[a] - n[a]);
        fl[size_t(a)] = int(std::floor(q[a]));
    }
    if (d[0] <= kA && d[1] <= kA && d[2] <= kA) return {0, {n[0], n[1], n[2]}};
    for (int k = 0; k < 3; ++k) {
        const int i = (k + 1) % 3, j = (k + 2) % 3;
        if (d[i] <= kB && d[j] <= kB) {
            std::array<int, 3> base{n[0], n[1], n[2]};
            base[size_t(k)] = fl[size_t(k)];
            return {1 << k, base};
        }
    }
    for (int k = 0; k < 3; ++k) {
        if (d[k] <= kC) {
            std::array<int, 3> base = fl;
            base[size_t(k)] = n[k];
            return {7 & ~(1 << k), base};
        }
    }
    return {7, fl};
}

// Is F a face, edge or vertex of G (or G itself)?
bool contains(const Feature& G, const Feature& F)
{
    if ((F.mask & ~G.mask) != 0) return false;
    for (int a = 0; a < 3; ++a) {
        const int d = F.base[size_t(a)] - G.base[size_t(a)];
        const bool spansG = (G.mask >> a) & 1, spansF = (F.mask >> a) & 1;
        if (spansG && !spansF) {
            if (d != 0 && d != 1) return false;
        } else if (d != 0) {
            return false;
        }
    }
    return true;
}

// The box around a feature's core (its lower vertex at the origin), tile units.
void coreBox(int mask, Vec3d& lo, Vec3d& hi)
{
    for (int a = 0; a < 3; ++a) {
        const bool spans = (mask >> a) & 1;
        switch (dimOf(mask)) {
        case 0: lo[a] = -kA; hi[a] = kA; break;
        case 1: lo[a] = spans ? kA : -kB; hi[a] = spans ? 1 - kA : kB; break;
        case 2: lo[a] = spans ? kB : -kC; hi[a] = spans ? 1 - kB : kC; break;
        default: lo[a] = kC; hi[a] = 1 - kC; break;
        }
    }
}

// L∞ distance from q to the box of F's core, and the Euclidean distance to F itself (the
// vertex, the edge's segment, the face's square).
double coreDistance(const Feature& F, const Vec3d& q)
{
    Vec3d lo, hi;
    coreBox(F.mask, lo, hi);
    double d = 0;
    for (int a = 0; a < 3; ++a) {
        const double x = q[a] - F.base[size_t(a)];
        d = std::max({d, lo[a] - x, x - hi[a]});
    }
    return d;
}

double distanceTo(const Feature& F, const Vec3d& q)
{
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
        const double x = q[a] - F.base[size_t(a)];
        const double e = ((F.mask >> a) & 1) ? std::max({0.0, -x, x - 1}) : x;
        d2 += e * e;
    }
    return std::sqrt(d2);
}

// Is F in the chain of features that may place points at q? The chain: the core's feature G
// and, nested in it, the nearest vertex of G within its reach, the nearest edge of G through
// that vertex within its reach and the nearest face of G through those — so two features that
// may both place points anywhere are always one inside the other. (Built only up to F's
// dimension, without allocating: the sampler asks it of every candidate.)
bool inChain(const Feature& F, const Vec3d& q)
{
    const Feature G = coreOf(q);
    const int dimF = dimOf(F.mask), dimG = dimOf(G.mask);
    if (dimF >= dimG) return F == G;
    if (!contains(G, F)) return false;
    Feature last{-1, {0, 0, 0}};
    for (int dim = 0; dim <= dimF; ++dim) {
        Feature best{-1, {0, 0, 0}};
        double bestD = 1e300;
        for (int m = 0; m < 8; ++m) {
            if (dimOf(m) != dim || (m & ~G.mask) != 0) continue;
            for (int o = 0; o < 8; ++o) {
                if ((o & ~(G.mask & ~m)) != 0) continue;
                const Feature C{m, {G.base[0] + (o & 1), G.base[1] + ((o >> 1) & 1), G.base[2] + ((o >> 2) & 1)}};
                if (last.mask >= 0 && !contains(C, last)) continue;
                if (coreDistance(C, q) > kReach[dim]) continue;
                const double d = distanceTo(C, q);
                if (d < bestD) { bestD = d; best = C; }
            }
        }
        if (best.mask >= 0) last = best;
    }
    return last == F;
}

// q (tile units) in the zone of the feature of @a mask at the origin.
bool inZone(int mask, const Vec3d& q) { return inChain(Feature{mask, {0, 0, 0}}, q); }

bool inCore(int mask, const Vec3d& q) { return coreOf(q) == Feature{mask, {0, 0, 0}}; }

// The vertices of a feature in canonical order: offsets o ⊆ mask, increasing.
std::vector<int> verticesOf(int mask)
{
    std::vector<int> out;
    for (int o = 0; o < 8; ++o) {
        if ((o & ~mask) == 0) out.push_back(o);
    }
    return out;
}

Vec3d offsetOf(int o) { return Vec3d(o & 1, (o >> 1) & 1, (o >> 2) & 1); }

int power(int k, int n)
{
    int p = 1;
    while (n-- > 0) p *= k;
    return p;
}

// The colours of the sub-feature (mask m, offset o) of a feature of mask M and colours C:
// digit n (base K) is the colour of the feature's n-th vertex.
int subColours(int M, int C, int m, int o, int K)
{
    const std::vector<int> mine = verticesOf(M);
    int out = 0, digit = 1;
    for (int v : verticesOf(m)) {
        const int at = int(std::find(mine.begin(), mine.end(), v | o) - mine.begin());
        out += (C / power(K, at)) % K * digit;
        digit *= K;
    }
    return out;
}

// The proper sub-features (mask, offset) of a feature of mask M: all masks m ⊂ M, offsets
// o ⊆ M \ m.
std::vector<std::pair<int, int>> subFeatures(int M)
{
    std::vector<std::pair<int, int>> out;
    for (int m = 0; m < 8; ++m) {
        if ((m & ~M) != 0 || m == M) continue;
        for (int o = 0; o < 8; ++o) {
            if ((o & ~(M & ~m)) == 0) out.emplace_back(m, o);
        }
    }
    return out;
}

// Distance-like value of q from block b: > 0 outside (at most the distance), < 0 inside.
double outside(const Block& b, const Vec3d& q)
{
    if (b.kind == BlockKind::Polytope) {
        double d = -1e300;
        for (const auto& pl : b.planes) d = std::max(d, pl[0] * q[0] + pl[1] * q[1] + pl[2] * q[2] - double(pl[3]));
        return d;
    }
    const Vec3d a(b.a[0], b.a[1], b.a[2]), e(b.b[0], b.b[1], b.b[2]);
    const Vec3d ab = e - a;
    const double l2 = ab.lengthSqr();
    const double t = l2 > 0 ? std::clamp((q - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
    return (q - (a + ab * t)).length() - double(b.radius);
}

std::vector<Vec3d> clusterOf(const Block& b)
{
    std::vector<Vec3d> P;
    P.reserve(b.cluster.size());
    for (const auto& v : b.cluster) P.emplace_back(v[0], v[1], v[2]);
    return P;
}

bool boxesMeet(const Block& a, const Block& b, double pad)
{
    for (size_t k = 0; k < 3; ++k) {
        if (a.boundsMin[k] > b.boundsMax[k] + pad || b.boundsMin[k] > a.boundsMax[k] + pad) return false;
    }
    return true;
}

} // namespace

AperiodicTiles::AperiodicTiles(const BlockTileParams& params, int colours)
    : mParams(params), mColours(colours)
{
    require(colours >= kMinColours && colours <= kMaxColours, "blocks", "aperiodic colours", "in [2, 4]",
            colours);
    if (!mParams.extraDiscs.empty()) {
        fail<ValueError>("blocks: aperiodic tiles take no user fractures (their coordinates are "
                         "those of one periodic tile)");
    }
    if (!mParams.authored.empty()) {
        fail<ValueError>("blocks: aperiodic tiles take no authored blocks (their coordinates are "
                         "those of one periodic tile)");
    }
    if (!mParams.fill) {
        fail<ValueError>("blocks: aperiodic tiles need fill (regions meet where their blocks do)");
    }
    mParams.resolveDefaults();
    mParams.validate();
    mParams.axis = mParams.axis.unit();
}

Vec3d AperiodicTiles::origin() const
{
    Vec3d u;
    for (int a = 0; a < 3; ++a) u[a] = mParams.tileSize * random::uniform(mParams.seed, kStreamOrigin, uint64_t(a));
    return u;
}

int AperiodicTiles::colour(int i, int j, int k) const
{
    return int(random::hashCoord(mParams.seed, kStreamColour, i, j, k) % uint64_t(mColours));
}

int AperiodicTiles::cubeKey(int i, int j, int k) const
{
    int key = 0;
    for (int o = 7; o >= 0; --o) key = key * mColours + colour(i + (o & 1), j + ((o >> 1) & 1), k + ((o >> 2) & 1));
    return key;
}

const AperiodicTiles::Region& AperiodicTiles::region(int mask, int colours, Task& task) const
{
    {
        std::lock_guard<std::mutex> lock(mMutex);
        auto it = mRegions.find({mask, colours});
        if (it != mRegions.end()) return *it->second;
    }
    // Its sub-features first (each level may run in parallel inside), then itself.
    for (const auto& [m, o] : subFeatures(mask)) region(m, subColours(mask, colours, m, o, mColours), task);
    make({mask, colours}, task);
    std::lock_guard<std::mutex> lock(mMutex);
    return *mRegions.at({mask, colours});
}

void AperiodicTiles::make(const Key& key, Task& task) const
{
    {
        std::lock_guard<std::mutex> lock(mMutex);
        if (mRegions.count(key)) return;
    }
    const int M = key.first, C = key.second; // (not a structured binding: lambdas below capture M)
    const BlockTileParams& p = mParams;
    const double s = p.tileSize;
    const double r = p.pointRadius, nr = p.neighbourRadius, w = p.fractureWidth;
    const uint64_t seed = random::hash(p.seed, kStreamRegion, uint64_t(M) * 1024 + uint64_t(C));

    // The sub-features' blocks, in this frame: obstacles.
    std::vector<Block> obstacles;
    {
        std::lock_guard<std::mutex> lock(mMutex);
        for (const auto& [m, o] : subFeatures(M)) {
            const Region& sub = *mRegions.at({m, subColours(M, C, m, o, mColours)});
            for (Block b : sub.blocks) {
                translate(b, offsetOf(o) * s);
                obstacles.push_back(std::move(b));
            }
        }
    }

    // 1. Points: Poisson in the zone's box (and 2r beyond: a sampler packs points against
    //    its box's faces, which would become facets), kept in the zone and away from the
    //    obstacles (where they are cut out, as a periodic tile's sampling would be).
    Vec3d lo, hi;
    coreBox(M, lo, hi);
    const double reach = kReach[dimOf(M)];
    lo -= Vec3d(reach);
    hi += Vec3d(reach);
    for (int a = 0; a < 3; ++a) {
        // Along the axes it spans, the zone stays within the feature: a point's core is a
        // feature containing it.
        if ((M >> a) & 1) {
            lo[a] = std::max(lo[a], 0.0);
            hi[a] = std::min(hi[a], 1.0);
        }
    }
    const Vec3d extent = (hi - lo) * s;
    const double side = std::max({extent[0], extent[1], extent[2]});
    // The obstacles near each cell of a grid over the box (their bounds padded by r).
    const double cell = 2 * r;
    const Vec3d gridLo = lo * s - Vec3d(cell);
    int dims[3];
    for (int a = 0; a < 3; ++a) dims[a] = int(std::ceil((extent[a] + 2 * cell) / cell));
    std::vector<std::vector<int>> near(size_t(dims[0]) * size_t(dims[1]) * size_t(dims[2]));
    auto cellOf = [&](double v, int a) { return std::clamp(int((v - gridLo[a]) / cell), 0, dims[a] - 1); };
    auto slot = [&](int i, int j, int k) { return (size_t(i) * size_t(dims[1]) + size_t(j)) * size_t(dims[2]) + size_t(k); };
    for (size_t n = 0; n < obstacles.size(); ++n) {
        const Block& o = obstacles[n];
        int a0[3], a1[3];
        for (int a = 0; a < 3; ++a) {
            a0[a] = cellOf(o.boundsMin[size_t(a)] - r, a);
            a1[a] = cellOf(o.boundsMax[size_t(a)] + r, a);
        }
        for (int i = a0[0]; i <= a1[0]; ++i)
            for (int j = a0[1]; j <= a1[1]; ++j)
                for (int k = a0[2]; k <= a1[2]; ++k) near[slot(i, j, k)].push_back(int(n));
    }
    auto admissible = [&](const Vec3d& q) {
        if (!inZone(M, q / s)) return false;
        for (int n : near[slot(cellOf(q[0], 0), cellOf(q[1], 1), cellOf(q[2], 2))]) {
            const Block& o = obstacles[size_t(n)];
            bool close = true;
            for (size_t a = 0; a < 3 && close; ++a) {
                close = q[a] > o.boundsMin[a] - r && q[a] < o.boundsMax[a] + r;
            }
            if (close && outside(o, q) < 0.75 * r) return false;
        }
        return true;
    };
    const double torus = side + 4 * nr;
    const Vec3d offset = Vec3d(2 * nr) - lo * s; // this frame → the torus [0, torus)³
    std::vector<Vec3d> pts;
    for (const Vec3d& q : poissonBox(lo * s - Vec3d(2 * r), hi * s + Vec3d(2 * r), r, seed, kPoints)) {
        if (admissible(q)) pts.push_back(q + offset);
    }
    task.check();

    // 2. Its own discs: one tile's worth around the zone's centre, the set directions of the
    //    tile set's seed.
    BlockTileParams pf = p;
    pf.seed = seed;
    std::vector<Disc> discs = makeDiscs(pf, int64_t(p.seed & 0x7fffffffffffffffULL));
    const Vec3d shift = (lo + hi) * 0.5 * s - Vec3d(0.5 * s) + offset;
    for (Disc& d : discs) d.center += shift;

    // 3. The tile's phases on the torus (wide enough that nothing wraps).
    auto region = std::make_shared<Region>();
    region->points = pts.size();
    if (!pts.empty()) {
        BlockTileParams pt = p;
        pt.tileSize = torus;
        const BlockTile tile = buildTile(pt, pts, std::move(discs), task);
        // 4. Keep the blocks with a cluster point in the core; back to this frame.
        for (Block b : tile.blocks) {
            translate(b, -offset);
            bool mine = false;
            for (const auto& v : b.cluster) {
                if (inCore(M, Vec3d(v[0], v[1], v[2]) / s)) { mine = true; break; }
            }
            if (!mine) { ++region->dropped; continue; }
            region->blocks.push_back(std::move(b));
        }
    }
    // Separated from the obstacles.
    tbb::parallel_for(size_t(0), region->blocks.size(), [&](size_t i) {
        Block& b = region->blocks[i];
        if (b.kind != BlockKind::Polytope) return;
        const std::vector<Vec3d> P = clusterOf(b);
        std::vector<std::array<double, 4>> all;
        for (const auto& q : b.planes) all.push_back({q[0], q[1], q[2], q[3]});
        bool changed = false;
        const auto edges = edgesOf(b);
        for (const Block& o : obstacles) {
            if (!boxesMeet(b, o, w)) continue;
            if (o.kind == BlockKind::Polytope) {
                if (!meets(b, edges, o, edgesOf(o), Vec3d(0), -w)) continue;
                // A plane with the cluster's points on this side and the obstacle on the other,
                // w beyond the obstacle: one of its faces, else the search of separatingPlane.
                std::vector<std::array<double, 4>> candidates;
                for (const auto& q : o.planes) {
                    candidates.push_back({-double(q[0]), -double(q[1]), -double(q[2]), -(double(q[3]) + w)});
                }
                std::vector<Vec3d> V;
                for (const auto& v : o.vertices) V.emplace_back(v[0], v[1], v[2]);
                Vec3d n;
                double m;
                if (!V.empty() && separatingPlane(P, V, n, m)) {
                    double lowest = 1e300;
                    for (const Vec3d& y : V) lowest = std::min(lowest, n.dot(y));
                    candidates.push_back({n[0], n[1], n[2], lowest - w});
                }
                std::pair<size_t, double> best{0, -1e300};
                std::array<double, 4> plane{};
                for (const auto& q : candidates) {
                    double slack = 1e300;
                    size_t kept = 0;
                    for (const Vec3d& x : P) {
                        const double h = q[3] - (q[0] * x[0] + q[1] * x[1] + q[2] * x[2]);
                        slack = std::min(slack, h);
                        kept += h > 0;
                    }
                    if (std::make_pair(kept, slack) > best) {
                        best = {kept, slack};
                        plane = q;
                    }
                }
                // A cluster that reaches round the obstacle (no plane keeps all its points)
                // keeps its shape: cutting it would leave a void; the two blocks then merge
                // there (one rock, no fracture).
                if (best.first < P.size()) continue;
                all.push_back(plane);
                changed = true;
            } else {
                // A point or segment obstacle: the plane through its nearest point to the
                // cluster's centroid, w/2 + its radius off.
                Vec3d c(0);
                for (const Vec3d& x : P) c += x;
                c /= double(P.size());
                const Vec3d a(o.a[0], o.a[1], o.a[2]), e(o.b[0], o.b[1], o.b[2]);
                const Vec3d ab = e - a;
                const double l2 = ab.lengthSqr();
                const double t = l2 > 0 ? std::clamp((c - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
                const Vec3d near = a + ab * t;
                Vec3d n = near - c;
                if (n.length() < 1e-9) continue;
                n = n.unit();
                all.push_back({n[0], n[1], n[2], n.dot(near) - double(o.radius) - w});
                changed = true;
            }
        }
        if (changed) setPolytope(b, all, P);
    });
    std::lock_guard<std::mutex> lock(mMutex);
    mRegions.emplace(key, std::move(region));
}

void AperiodicTiles::prepare(const std::vector<int>& keys, Task& task) const
{
    // The regions the keys need, by level; each level in parallel.
    std::set<Key> levels[4];
    for (int key : keys) {
        require(key >= 0 && key < cubeKeys(), "blocks", "cube key", "in [0, colours^8)", key);
        for (int M : {0, 1, 2, 4, 6, 5, 3, 7}) {
            levels[dimOf(M)].insert({M, subColours(7, key, M, 0, mColours)});
        }
    }
    for (int d = 3; d >= 1; --d) {
        for (const Key& k : levels[d]) {
            for (const auto& [m, o] : subFeatures(k.first)) {
                levels[dimOf(m)].insert({m, subColours(k.first, k.second, m, o, mColours)});
            }
        }
    }
    // Progress: the share of these regions made (the task's current phase).
    size_t total = 0;
    for (const auto& level : levels) total += level.size();
    std::atomic<size_t> made{0};
    for (auto& level : levels) {
        std::vector<Key> todo(level.begin(), level.end());
        tbb::parallel_for(size_t(0), todo.size(), [&](size_t i) {
            make(todo[i], task);
            task.advance(double(++made) / double(total));
        });
        task.check();
    }
}

std::shared_ptr<const BlockTile> AperiodicTiles::cubeTile(int key) const
{
    Task task;
    return cubeTile(key, task);
}

std::shared_ptr<const BlockTile> AperiodicTiles::cubeTile(int key, Task& task) const
{
    {
        std::lock_guard<std::mutex> lock(mMutex);
        auto it = mCubes.find(key);
        if (it != mCubes.end()) return it->second;
    }
    prepare({key}, task);
    auto tile = std::make_shared<BlockTile>();
    auto ids = std::make_shared<std::vector<float>>();
    tile->params = mParams;
    {
        std::lock_guard<std::mutex> lock(mMutex);
        int slot = 0;
        for (int M : {0, 1, 2, 4, 6, 5, 3, 7}) {
            const int C = subColours(7, key, M, 0, mColours);
            const Region& r = *mRegions.at({M, C});
            for (Block b : r.blocks) {
                translate(b, origin());
                tile->blocks.push_back(std::move(b));
            }
            tile->stats.points += r.points;
            const size_t n = std::min<size_t>(r.blocks.size(), kIdSlot);
            const uint64_t offset = random::hash(mParams.seed, kStreamIds, uint64_t(M) << 32 | uint64_t(C)) %
                                    uint64_t(kIdSlot - n + 1);
            for (size_t i = 0; i < r.blocks.size(); ++i) {
                // (a region of over 8192 blocks wraps round its slot)
                ids->push_back(float(size_t(slot) * kIdSlot + (offset + i) % kIdSlot));
            }
            ++slot;
        }
        tile->stats.blocks = tile->blocks.size();
        mCubeIds.emplace(key, std::move(ids));
        auto [it, fresh] = mCubes.emplace(key, std::move(tile));
        return it->second;
    }
}

std::shared_ptr<const std::vector<float>> AperiodicTiles::cubeIds(int key, Task& task) const
{
    cubeTile(key, task);
    std::lock_guard<std::mutex> lock(mMutex);
    return mCubeIds.at(key);
}

std::array<size_t, 4> AperiodicTiles::regionsMade() const
{
    std::lock_guard<std::mutex> lock(mMutex);
    std::array<size_t, 4> n{0, 0, 0, 0};
    for (const auto& [k, r] : mRegions) ++n[size_t(dimOf(k.first))];
    return n;
}

// ---- the tiling as a field ---------------------------------------------------------------

namespace {

// Copies of a cube tile's blocks: the cubes of its colouring in the box.
class KeyPresence final : public Presence
{
public:
    KeyPresence(std::shared_ptr<const std::vector<int32_t>> keys, std::array<int, 3> lo,
                std::array<int, 3> dim, int key, BBoxd bounds)
        : mKeys(std::move(keys)), mLo(lo), mDim(dim), mKey(key), mBounds(bounds) {}
    bool present(int, int ix, int iy, int iz) const override
    {
        const int64_t x = int64_t(ix) - mLo[0], y = int64_t(iy) - mLo[1], z = int64_t(iz) - mLo[2];
        if (x < 0 || y < 0 || z < 0 || x >= mDim[0] || y >= mDim[1] || z >= mDim[2]) return false;
        return (*mKeys)[size_t((x * mDim[1] + y) * mDim[2] + z)] == mKey;
    }
    BBoxd bounds() const override { return mBounds; }

private:
    std::shared_ptr<const std::vector<int32_t>> mKeys;
    std::array<int, 3> mLo, mDim;
    int mKey;
    BBoxd mBounds;
};

class AperiodicField final : public Field
{
public:
    std::shared_ptr<const AperiodicTiles> tiles;
    std::array<int, 3> lo{}, dim{};
    std::shared_ptr<const std::vector<int32_t>> keys; ///< per cube: its colouring, -1 left out
    std::vector<FieldPtr> parts;      ///< per colouring (null: absent)
    std::vector<BBoxd> cubeBounds;    ///< a cube tile's blocks, cube frame, warp included
    BBoxd reach;                      ///< all cube tiles' blocks, cube frame
    BBoxd box;
    bool any = false;                 ///< some colouring has a copy
    double cap = 0, lip = 1, amp = 0;

    void evalBatch(const Batch& b, float* out) const override { eval(b, out, nullptr); }
    void evalIdBatch(const Batch& b, float* out, float* id) const override { eval(b, out, id); }
    BBoxd bounds() const override { return box; }
    double modulus(double r) const override { return r + 2.0 * amp; }
    double lipschitz() const override { return lip; }
    bool exact() const override { return false; }

private:
    void eval(const Batch& b, float* out, float* id) const
    {
        Vec3d blo(1e300), bhi(-1e300);
        for (int i = 0; i < b.n; ++i) {
            blo = minComponent(blo, Vec3d(b.x[i], b.y[i], b.z[i]));
            bhi = maxComponent(bhi, Vec3d(b.x[i], b.y[i], b.z[i]));
        }
        std::fill(out, out + b.n, float(cap));
        if (id) std::fill(id, id + b.n, kNoId);
        if (b.n == 0 || !any) return;
        const double s = tiles->size();
        // A cube whose blocks all stay farther than the cap from the batch changes nothing.
        int i0[3], i1[3];
        for (int a = 0; a < 3; ++a) {
            i0[a] = std::max(lo[size_t(a)], int(std::floor((blo[a] - cap - reach.max()[a]) / s)));
            i1[a] = std::min(lo[size_t(a)] + dim[size_t(a)] - 1, int(std::floor((bhi[a] + cap - reach.min()[a]) / s)));
        }
        std::vector<int> used; // the colourings met (a coarse bake's leaf can meet dozens)
        for (int x = i0[0]; x <= i1[0]; ++x)
            for (int y = i0[1]; y <= i1[1]; ++y)
                for (int z = i0[2]; z <= i1[2]; ++z) {
                    const int k = (*keys)[size_t(((x - lo[0]) * dim[1] + (y - lo[1])) * dim[2] + (z - lo[2]))];
                    if (k < 0 || !parts[size_t(k)] || std::find(used.begin(), used.end(), k) != used.end()) continue;
                    const BBoxd& cb = cubeBounds[size_t(k)];
                    const Vec3d o = Vec3d(x, y, z) * s;
                    bool near = true;
                    for (int a = 0; a < 3 && near; ++a) {
                        near = cb.min()[a] + o[a] < bhi[a] + cap && cb.max()[a] + o[a] > blo[a] - cap;
                    }
                    if (near) used.push_back(k);
                }
        alignas(64) float v[kMaxBatch], vid[kMaxBatch];
        // In colouring order: the same minimum and id whichever cubes the batch met first.
        std::sort(used.begin(), used.end());
        for (const int k : used) {
            if (id) {
                parts[size_t(k)]->evalIdBatch(b, v, vid);
                for (int i = 0; i < b.n; ++i) {
                    if (v[i] < out[i]) { out[i] = v[i]; id[i] = vid[i]; }
                }
            } else {
                parts[size_t(k)]->evalBatch(b, v);
                for (int i = 0; i < b.n; ++i) out[i] = std::min(out[i], v[i]);
            }
        }
    }
};

} // namespace

FieldPtr aperiodicField(std::shared_ptr<const AperiodicTiles> tiles, const std::array<int, 3>& lo,
                        const std::array<int, 3>& hi, Task& task,
                        const std::function<bool(int, int, int)>& cubes, const KeyPresenceFn& presence)
{
    if (!tiles) fail<ValueError>("blocks: aperiodic tiles are null");
    auto f = std::make_shared<AperiodicField>();
    f->tiles = tiles;
    f->lo = lo;
    double count = 1;
    for (int a = 0; a < 3; ++a) {
        require(hi[size_t(a)] >= lo[size_t(a)], "blocks", "cube range", "non-empty", hi[size_t(a)] - lo[size_t(a)]);
        f->dim[size_t(a)] = hi[size_t(a)] - lo[size_t(a)] + 1;
        count *= f->dim[size_t(a)];
    }
    require(count <= 5e7, "blocks", "cubes of the aperiodic tiling", "at most 5e7", count);
    auto keys = std::make_shared<std::vector<int32_t>>(size_t(count), -1);
    f->parts.resize(size_t(tiles->cubeKeys()));
    f->cubeBounds.resize(size_t(tiles->cubeKeys()));
    std::set<int> present;
    for (int ix = 0; ix < f->dim[0]; ++ix)
        for (int iy = 0; iy < f->dim[1]; ++iy)
            for (int iz = 0; iz < f->dim[2]; ++iz) {
                const int x = lo[0] + ix, y = lo[1] + iy, z = lo[2] + iz;
                if (cubes && !cubes(x, y, z)) continue;
                const int k = tiles->cubeKey(x, y, z);
                (*keys)[size_t((ix * f->dim[1] + iy) * f->dim[2] + iz)] = k;
                present.insert(k);
            }
    f->keys = keys;
    tiles->prepare(std::vector<int>(present.begin(), present.end()), task);
    const double s = tiles->size();
    const double amp = tiles->params().relief.amplitude;
    f->amp = amp;
    f->cap = s / 4.0;
    bool first = true;
    for (int k : present) {
        task.check();
        auto tile = tiles->cubeTile(k, task);
        if (tile->blocks.empty()) continue;
        BBoxd cb(Vec3d(1e300), Vec3d(-1e300));
        for (const Block& b : tile->blocks) {
            cb.expand(BBoxd(Vec3d(b.boundsMin[0], b.boundsMin[1], b.boundsMin[2]) - Vec3d(amp),
                            Vec3d(b.boundsMax[0], b.boundsMax[1], b.boundsMax[2]) + Vec3d(amp)));
        }
        TileFieldOptions o;
        o.blockIds = tiles->cubeIds(k, task);
        if (presence) {
            o.presence = presence(k, *tile);
        } else {
            // The bounds of this colouring's copies.
            BBoxd kb;
            bool any = false;
            for (int ix = 0; ix < f->dim[0]; ++ix)
                for (int iy = 0; iy < f->dim[1]; ++iy)
                    for (int iz = 0; iz < f->dim[2]; ++iz) {
                        if ((*keys)[size_t((ix * f->dim[1] + iy) * f->dim[2] + iz)] != k) continue;
                        const Vec3d off = Vec3d(lo[0] + ix, lo[1] + iy, lo[2] + iz) * s;
                        const BBoxd bb(cb.min() + off, cb.max() + off);
                        if (!any) { kb = bb; any = true; } else kb.expand(bb);
                    }
            o.presence = std::make_shared<KeyPresence>(keys, lo, f->dim, k, kb);
        }
        const BBoxd kb = o.presence->bounds();
        if (kb.min()[0] > kb.max()[0]) continue; // no copy present
        f->cubeBounds[size_t(k)] = cb;
        if (first) f->reach = cb; else f->reach.expand(cb);
        f->parts[size_t(k)] = tileField(tile, o);
        f->lip = f->parts[size_t(k)]->lipschitz();
        if (first) { f->box = kb; first = false; } else f->box.expand(kb);
    }
    if (first) f->box = BBoxd(Vec3d(0), Vec3d(-1));
    f->any = !first;
    return f;
}

} // namespace blocks
} // namespace rockvdb
