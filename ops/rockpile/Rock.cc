// SPDX-License-Identifier: Apache-2.0
// Rock tiles: one rock (rock-piles §4–§5) — the discrete anisotropic Voronoi cell of its seed
// among the 27 cells around it (claiming only the halves of its neighbours that face it), its
// contact points with the neighbouring cells, and the spheroidal erosion that rounds it
// except near its contacts. makeRock runs the phases in that order; each phase is a function
// below.
#include <rockvdb/rockpile/RockTiles.h>

#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridUtil.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace rockvdb {
namespace rockpile {

using openvdb::Coord;

float Rock::at(const Coord& v) const
{
    const Coord l = v - origin;
    if (l[0] < 0 || l[1] < 0 || l[2] < 0 || l[0] >= dims[0] || l[1] >= dims[1] ||
        l[2] >= dims[2]) {
        return 0.0f;
    }
    return rho[size_t((l[0] * dims[1] + l[1]) * dims[2] + l[2])];
}

size_t Rock::solidVoxels() const
{
    return size_t(std::count_if(rho.begin(), rho.end(), [](float r) { return r > 0.5f; }));
}

namespace {

// A dense box of values indexed by global voxel coordinates.
template <typename T>
struct Box
{
    Coord origin, dims;
    std::vector<T> v;
    Box(const Coord& o, const Coord& d, T fill) : origin(o), dims(d), v(size_t(d[0]) * d[1] * d[2], fill) {}
    bool inside(const Coord& c) const
    {
        const Coord l = c - origin;
        return l[0] >= 0 && l[1] >= 0 && l[2] >= 0 && l[0] < dims[0] && l[1] < dims[1] && l[2] < dims[2];
    }
    size_t index(const Coord& c) const
    {
        const Coord l = c - origin;
        return size_t((l[0] * dims[1] + l[1]) * dims[2] + l[2]);
    }
    T& operator[](const Coord& c) { return v[index(c)]; }
    const T& operator[](const Coord& c) const { return v[index(c)]; }
};

constexpr int16_t kUnknown = -1;
constexpr int16_t kBarred = -2; // nearest to the rock's seed but in a half it may not claim

// Two rocks whose cells are two apart along an axis do not see each other's seeds (each
// competes with its own 27 cells), so both could claim a voxel of the cell between them. A
// rock may therefore claim only the half of a neighbouring cell that faces its own cell
// (per axis; with odd m the middle voxel layer goes to the rock of that cell): a function of
// its cell alone, so the rocks of a region stay the same in every cube, and no voxel is ever
// in two rocks. Departure from the rock-piles paper, which does not say how far a cell's
// competitors reach.
bool claimable(const Coord& v, const Coord& cell, int m)
{
    for (int a = 0; a < 3; ++a) {
        const int c = int(std::floor(double(v[a]) / m)) - cell[a];
        const int l = v[a] - (cell[a] + c) * m; // 0..m-1 inside that cell
        if (c > 0 && !(2 * l + 1 < m)) return false;
        if (c < 0 && !(2 * l + 1 > m)) return false;
    }
    return true;
}

// The competitors: every seed of the 27 cells around the rock's cell (§3); @a self is the
// rock's own seed among them.
std::vector<Seed> competitors(const RockTileParams& p, const Coord& cell, int index,
                              const Colouring& colouring, int& self)
{
    std::vector<Seed> seeds;
    self = -1;
    for (int i = -1; i <= 1; ++i)
        for (int j = -1; j <= 1; ++j)
            for (int k = -1; k <= 1; ++k) {
                const auto s = cellSeeds(p, cell.offsetBy(i, j, k), colouring);
                if (i == 0 && j == 0 && k == 0) self = int(seeds.size()) + index;
                seeds.insert(seeds.end(), s.begin(), s.end());
            }
    if (self < 0 || index >= int(cellSeeds(p, cell, colouring).size())) {
        fail<ValueError>("rockpile: cell has no seed ", index);
    }
    return seeds;
}

// The nearest seed of voxel v (centre (v + ½)/m cells); ties go to the smaller key.
// d_k as a quadratic form Q_k = Σ_a w_a e_a e_aᵀ / g_k (w_a = 1/α_a², 6 coefficients), in
// single precision relative to the rock's cell (every position within 2 cells), the seeds
// laid out by coefficient so the distance loops vectorise.
class NearestSeed
{
public:
    NearestSeed(const std::vector<Seed>& seeds, const Coord& cell, int m)
        : mSeeds(seeds), mN(seeds.size()), mInvM(1.0 / double(m)), mOrigin(cell[0], cell[1], cell[2]),
          mSoa(10 * mN)
    {
        float* px = mSoa.data();
        for (size_t s = 0; s < mN; ++s) {
            const Seed& k = seeds[s];
            px[s] = float(k.p[0] - mOrigin[0]);
            px[mN + s] = float(k.p[1] - mOrigin[1]);
            px[2 * mN + s] = float(k.p[2] - mOrigin[2]);
            double q[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
            for (int a = 0; a < 3; ++a)
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) q[i][j] += k.weight[a] * k.frame[a][i] * k.frame[a][j] / k.g;
            px[3 * mN + s] = float(q[0][0]);
            px[4 * mN + s] = float(q[1][1]);
            px[5 * mN + s] = float(q[2][2]);
            px[6 * mN + s] = float(2 * q[0][1]);
            px[7 * mN + s] = float(2 * q[0][2]);
            px[8 * mN + s] = float(2 * q[1][2]);
        }
    }

    int16_t operator()(const Coord& v)
    {
        const size_t ns = mN;
        const float* px = mSoa.data();
        const float *py = px + ns, *pz = py + ns, *q00 = pz + ns, *q11 = q00 + ns,
                    *q22 = q11 + ns, *q01 = q22 + ns, *q02 = q01 + ns, *q12 = q02 + ns;
        float* __restrict d = mSoa.data() + 9 * ns;
        const float x = float((v[0] + 0.5) * mInvM - mOrigin[0]),
                    y = float((v[1] + 0.5) * mInvM - mOrigin[1]),
                    z = float((v[2] + 0.5) * mInvM - mOrigin[2]);
        for (size_t s = 0; s < ns; ++s) {
            const float a = x - px[s], b = y - py[s], c = z - pz[s];
            d[s] = q00[s] * a * a + q11[s] * b * b + q22[s] * c * c + q01[s] * a * b +
                   q02[s] * a * c + q12[s] * b * c;
        }
        int best = 0;
        for (size_t s = 1; s < ns; ++s) {
            if (d[s] < d[best] || (d[s] == d[best] && mSeeds[s].key < mSeeds[size_t(best)].key)) {
                best = int(s);
            }
        }
        return int16_t(best);
    }

private:
    const std::vector<Seed>& mSeeds;
    size_t mN;
    double mInvM;
    Vec3d mOrigin;
    std::vector<float> mSoa; // px, py, pz, q00, q11, q22, q01, q02, q12, distances
};

// The discrete Voronoi cell of §4: the voxels flooded from the seed's voxel through voxels it
// owns, within its cell and the halves of the 26 around it that face it (claimable); which
// seeds own a face neighbour of it; its voxel bounds.
struct VoronoiCell
{
    Box<int16_t> label;          // owner of every voxel the flood looked at (else kUnknown)
    std::vector<Coord> voxels;   // the cell, in flood order
    std::vector<uint8_t> touches; // per competitor: owns a face neighbour of the cell
    Coord start, lo, hi;
};

VoronoiCell voronoiCell(const Seed& seed, const Coord& cell, int m, int self, size_t ns,
                        NearestSeed& owner)
{
    VoronoiCell v{Box<int16_t>(scaled(cell.offsetBy(-1, -1, -1), m), Coord(3 * m), kUnknown),
                  {}, std::vector<uint8_t>(ns, 0), Coord(), Coord(std::numeric_limits<int>::max()),
                  Coord(std::numeric_limits<int>::min())};
    Box<int16_t>& label = v.label;
    std::vector<Coord>& queue = v.voxels;
    const Vec3d& ps = seed.p;
    v.start = Coord(int(std::floor(ps[0] * m)), int(std::floor(ps[1] * m)), int(std::floor(ps[2] * m)));
    for (int i = -1; i <= 1 && queue.empty(); ++i)
        for (int j = -1; j <= 1 && queue.empty(); ++j)
            for (int k = -1; k <= 1 && queue.empty(); ++k) {
                const Coord c = v.start.offsetBy(i, j, k);
                label[c] = owner(c);
                if (label[c] == self && !claimable(c, cell, m)) label[c] = kBarred;
                if (label[c] == self) queue.push_back(c);
            }
    for (size_t q = 0; q < queue.size(); ++q) {
        const Coord c = queue[q];
        v.lo = Coord::minComponent(v.lo, c);
        v.hi = Coord::maxComponent(v.hi, c);
        static const int kFace[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        for (const auto& d : kFace) {
            const Coord u = c.offsetBy(d[0], d[1], d[2]);
            if (!label.inside(u)) continue;
            if (label[u] == kUnknown) {
                label[u] = owner(u);
                if (label[u] == self && !claimable(u, cell, m)) label[u] = kBarred;
                if (label[u] == self) queue.push_back(u);
            }
            if (label[u] >= 0 && label[u] != self) v.touches[size_t(label[u])] = 1;
        }
    }
    return v;
}

// §5 contact points: c_kj on [p_k p_j] with d_k(c) = d_j(c) (bisection), kept where the face
// between the two cells really passes: no third seed nearer, and the discrete cells touch
// there — two face neighbours among the 8 voxels round c, one of the rock, one of the other
// cell (near a junction a third cell's voxels can fill the gap). The contact is the middle of
// the nearest such pair: on the discrete face, so both rocks' surfaces pass through it. Only
// seeds owning a face neighbour of the rock can qualify (the flood labelled every face
// neighbour).
std::vector<Contact> contactPoints(const std::vector<Seed>& seeds, int self,
                                   const VoronoiCell& cell, int m)
{
    std::vector<Contact> contacts;
    const size_t ns = seeds.size();
    const Box<int16_t>& label = cell.label;
    auto labelAt = [&](const Coord& v) { return label.inside(v) ? label[v] : kUnknown; };
    const Seed& a = seeds[size_t(self)];
    for (int16_t j = 0; j < int16_t(ns); ++j) {
        if (!cell.touches[size_t(j)]) continue;
        const Seed& b = seeds[size_t(j)];
        double t0 = 0, t1 = 1;
        for (int it = 0; it < 48; ++it) {
            const double t = 0.5 * (t0 + t1);
            const Vec3d c = a.p + (b.p - a.p) * t;
            (a.distance(c) < b.distance(c) ? t0 : t1) = t;
        }
        const Vec3d c = a.p + (b.p - a.p) * (0.5 * (t0 + t1));
        const double dc = a.distance(c);
        bool kept = true;
        for (size_t s = 0; s < ns && kept; ++s) {
            if (int(s) != self && int(s) != j && seeds[s].distance(c) < dc * (1 - 1e-9)) kept = false;
        }
        if (!kept) continue;
        const Vec3d cv = c * double(m) - Vec3d(0.5); // voxel units (voxel v's centre at v)
        const Coord corner(int(std::floor(cv[0])), int(std::floor(cv[1])), int(std::floor(cv[2])));
        int16_t o[8];
        for (int q = 0; q < 8; ++q) o[q] = labelAt(corner.offsetBy(q >> 2, (q >> 1) & 1, q & 1));
        double best = std::numeric_limits<double>::max();
        Vec3d point;
        for (int q = 0; q < 8; ++q)
            for (int bit = 1; bit < 8; bit <<= 1) {
                const int u = q | bit; // the 12 edges of the 2x2x2 block, in a fixed order
                if (u == q) continue;
                if (!((o[q] == self && o[u] == j) || (o[q] == j && o[u] == self))) continue;
                const Vec3d mid = Vec3d(corner[0] + (q >> 2), corner[1] + ((q >> 1) & 1), corner[2] + (q & 1)) +
                                  Vec3d(bit == 4 ? 0.5 : 0, bit == 2 ? 0.5 : 0, bit == 1 ? 0.5 : 0);
                const double dd = (mid - cv).lengthSqr();
                if (dd < best) {
                    best = dd;
                    point = mid;
                }
            }
        if (best < std::numeric_limits<double>::max()) contacts.push_back({point, b.key, b.p});
    }
    return contacts;
}

// §5 erosion over the cell's box grown by one voxel: ρ = 1 in the cell, damped near contacts
// by ω = min ω_kj (corner cubes) or by the Gaussian resistance (periodic). Sets the rock's
// box and ρ.
void erode(const RockTileParams& p, const VoronoiCell& cell, Rock& rock)
{
    const int m = p.voxelsPerCell;
    const std::vector<Coord>& queue = cell.voxels;
    rock.origin = cell.lo.offsetBy(-1, -1, -1);
    rock.dims = (cell.hi - cell.lo).offsetBy(3, 3, 3);
    Box<float> rho(rock.origin, rock.dims, 0.0f);
    Box<float> omega(rock.origin, rock.dims, 1.0f);
    for (const Coord& c : queue) rho[c] = 1.0f;
    // (At least a voxel of no erosion, so every contact survives the discretisation.)
    const double a = std::max(p.contactInner * m, 1.0), b = std::max(p.contactOuter * m, a + 1.0);
    // Arches §5: r is the Poisson radius of [LD06], whose disks of radius r do not overlap:
    // half our seed spacing (the minimum distance between seeds).
    const double r2 = std::pow(0.5 * (p.poissonRadius > 0 ? p.poissonRadius : 0.8) * m, 2);
    for (const Coord& c : queue) {
        double w = 1.0;
        for (const Contact& ct : rock.contacts) {
            const double d = (Vec3d(c[0], c[1], c[2]) - ct.point).length();
            if (p.tiling == Tiling::Periodic) {
                w = std::min(w, 1.0 - std::exp(-d * d / r2));
            } else {
                w = std::min(w, d < a ? 0.0 : d < b ? (d - a) / (b - a) : 1.0);
            }
        }
        omega[c] = float(w);
    }
    // Flat indices: the cell's voxels, their 26 neighbours and 6 face neighbours (the box
    // has a voxel of margin all round).
    std::vector<size_t> cellIndex(queue.size());
    for (size_t q = 0; q < queue.size(); ++q) cellIndex[q] = rho.index(queue[q]);
    const ptrdiff_t sx = ptrdiff_t(rock.dims[1]) * rock.dims[2], sy = rock.dims[2];
    ptrdiff_t nb26[26], nb6[6];
    {
        int q = 0, f = 0;
        for (int i = -1; i <= 1; ++i)
            for (int j = -1; j <= 1; ++j)
                for (int k = -1; k <= 1; ++k) {
                    if (!(i || j || k)) continue;
                    nb26[q++] = i * sx + j * sy + k;
                    if (std::abs(i) + std::abs(j) + std::abs(k) == 1) nb6[f++] = i * sx + j * sy + k;
                }
    }
    std::vector<float> next;
    const float rate = float(p.erosionRate) / 26.0f;
    for (int step = 0; step < p.erosionSteps; ++step) {
        next = rho.v;
        const float* cur = rho.v.data();
        for (size_t q = 0; q < cellIndex.size(); ++q) {
            const size_t i = cellIndex[q];
            const float r = cur[i];
            if (r <= 0.0f) continue;
            // Surface voxels only (a face neighbour empty or of another rock); the amount
            // grows with the exposure over the 26 neighbours: corners round first
            // (spheroidal weathering).
            bool surface = false;
            for (ptrdiff_t o : nb6) surface |= cur[size_t(ptrdiff_t(i) + o)] <= 0.0f;
            if (!surface) continue;
            float missing = 0.0f;
            for (ptrdiff_t o : nb26) missing += 1.0f - cur[size_t(ptrdiff_t(i) + o)];
            next[i] = std::max(0.0f, r - rate * missing * omega.v[i]);
        }
        rho.v.swap(next);
    }
    rock.rho = std::move(rho.v);
}

} // namespace

Rock makeRock(const RockTileParams& p, const Coord& cell, int index, const Colouring& colouring)
{
    const int m = p.voxelsPerCell;
    int self = -1;
    const std::vector<Seed> seeds = competitors(p, cell, index, colouring, self);
    Rock rock;
    rock.seed = seeds[size_t(self)];
    NearestSeed owner(seeds, cell, m);
    const VoronoiCell voronoi = voronoiCell(rock.seed, cell, m, self, seeds.size(), owner);
    rock.voronoiVoxels = voronoi.voxels.size();
    if (voronoi.voxels.empty()) {
        rock.origin = voronoi.start;
        rock.dims = Coord(0);
        return rock;
    }
    rock.contacts = contactPoints(seeds, self, voronoi, m);
    erode(p, voronoi, rock);
    return rock;
}

} // namespace rockpile
} // namespace rockvdb
