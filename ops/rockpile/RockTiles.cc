#include "RockTiles.h"

#include <core/Error.h>
#include <core/Random.h>
#include <core/Sampling.h>

#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <tuple>

namespace rockvdb {
namespace rockpile {

using openvdb::Coord;

namespace {

// Random streams (Random.h): one per kind of quantity.
enum Stream : uint64_t {
    kCount = 0x5eed5c0, kPosition, kFrame, kScale, kG, kKey, kPeriodic
};

int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

Coord mul(const Coord& c, int s) { return Coord(c[0] * s, c[1] * s, c[2] * s); }

// The feature owning a cell (§3: the vertex, edge, face or cube whose region's
// 1-neighbourhood holds it, in that order). Per axis the cell is near the lattice plane
// below (local index 0, 1), near the one above (n − 2, n − 1), or in between (mid).
struct Feature
{
    std::array<int, 3> plane;  // near axes: lattice coordinate of the plane; mid: cube
    std::array<bool, 3> near;
    std::array<int, 3> rel;    // near: cell − n·plane ∈ {−2..1}; mid: local index
};

Feature featureOf(const Coord& cell, int n)
{
    Feature f;
    for (int a = 0; a < 3; ++a) {
        const int cube = floorDiv(cell[a], n), l = cell[a] - n * cube;
        if (l <= 1) {
            f.near[a] = true; f.plane[a] = cube; f.rel[a] = l;
        } else if (l >= n - 2) {
            f.near[a] = true; f.plane[a] = cube + 1; f.rel[a] = l - n;
        } else {
            f.near[a] = false; f.plane[a] = cube; f.rel[a] = l;
        }
    }
    return f;
}

// A hash of what the cell's seeds may depend on: the owner's type, its vertices' colours (in
// canonical order: bits over the mid axes) and the cell's place relative to it.
uint64_t featureKey(const Feature& f, const Colouring& colouring, uint64_t seed)
{
    uint64_t h = random::hash(seed, kKey, uint64_t(f.near[0]) | uint64_t(f.near[1]) << 1 |
                                              uint64_t(f.near[2]) << 2);
    std::array<int, 3> mid;
    int nm = 0;
    for (int a = 0; a < 3; ++a) if (!f.near[a]) mid[nm++] = a;
    for (int b = 0; b < (1 << nm); ++b) {
        std::array<int, 3> v = f.plane;
        for (int q = 0; q < nm; ++q) v[mid[q]] += (b >> q) & 1;
        h = random::mix64(h + uint64_t(colouring(v[0], v[1], v[2])) + 1);
    }
    for (int a = 0; a < 3; ++a) h = random::mix64(h + uint64_t(uint32_t(f.rel[a] + 1000)));
    return h;
}

// A uniformly random rotation (Shoemake's quaternion from three uniforms).
std::array<Vec3d, 3> randomFrame(uint64_t h)
{
    const double u1 = random::uniform(h, kFrame, 0), u2 = random::uniform(h, kFrame, 1),
                 u3 = random::uniform(h, kFrame, 2);
    const double s1 = std::sqrt(1 - u1), s2 = std::sqrt(u1), t1 = 2 * M_PI * u2, t2 = 2 * M_PI * u3;
    const double x = s1 * std::sin(t1), y = s1 * std::cos(t1), z = s2 * std::sin(t2),
                 w = s2 * std::cos(t2);
    return {{Vec3d(1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)),
             Vec3d(2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)),
             Vec3d(2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y))}};
}

Seed makeSeed(const TileParams& p, uint64_t h, const Vec3d& position)
{
    Seed s;
    s.p = position;
    s.key = h;
    s.frame = randomFrame(h);
    for (int a = 0; a < 3; ++a) {
        const double v = p.anisotropy[a];
        s.scale[a] = random::uniform(h, kScale, uint64_t(a), v * (1.0 - p.anisotropyJitter), v);
        s.weight[a] = 1.0 / (s.scale[a] * s.scale[a]);
    }
    s.g = random::uniform(h, kG, 0, 1.0, p.gMax);
    return s;
}

// The periodic tile's Poisson-sphere seeds, binned by cell (cached per parameter set).
const std::vector<std::vector<Vec3d>>& periodicSeeds(const TileParams& p)
{
    static std::mutex mutex;
    static std::map<std::tuple<int, double, uint64_t>, std::vector<std::vector<Vec3d>>> cache;
    const auto key = std::make_tuple(p.n, p.poissonRadius, p.seed);
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
    const double r = p.poissonRadius > 0 ? p.poissonRadius : 0.8;
    const auto points = poissonPeriodic(double(p.n), r, p.seed, kPeriodic);
    std::vector<std::vector<Vec3d>> cells(size_t(p.n * p.n * p.n));
    for (const Vec3d& q : points) {
        const int i = std::min(p.n - 1, int(q[0])), j = std::min(p.n - 1, int(q[1])),
                  k = std::min(p.n - 1, int(q[2]));
        cells[size_t((i * p.n + j) * p.n + k)].push_back(q);
    }
    if (cache.size() > 16) cache.clear();
    return cache.emplace(key, std::move(cells)).first->second;
}

// R3 low-discrepancy sequence (Roberts 2018): frac(offset + i·(1/φ₃, 1/φ₃², 1/φ₃³)).
Vec3d r3(const Vec3d& offset, int i)
{
    constexpr double g = 1.2207440845557199;
    const Vec3d a(1.0 / g, 1.0 / (g * g), 1.0 / (g * g * g));
    Vec3d q = offset + a * double(i);
    for (int c = 0; c < 3; ++c) q[c] -= std::floor(q[c]);
    return q;
}

} // namespace

// ---- seeds --------------------------------------------------------------------------------

std::vector<Seed> cellSeeds(const TileParams& p, const Coord& cell, const Colouring& colouring)
{
    std::vector<Seed> out;
    if (p.tiling == Tiling::Periodic) {
        const Coord cube(floorDiv(cell[0], p.n), floorDiv(cell[1], p.n), floorDiv(cell[2], p.n));
        const Coord l = cell - mul(cube, p.n);
        const auto& bins = periodicSeeds(p)[size_t((l[0] * p.n + l[1]) * p.n + l[2])];
        for (size_t i = 0; i < bins.size(); ++i) {
            // The key names the seed, whichever image: images never meet in one 27-cell
            // neighbourhood (n >= 3).
            const uint64_t h = random::hashCoord(p.seed, kKey, l[0], l[1], l[2] * 64 + int(i));
            const Vec3d shift(cube[0] * p.n, cube[1] * p.n, cube[2] * p.n);
            Seed s = makeSeed(p, h, bins[i] + shift);
            s.g = 1.0; // arches §5: the Euclidean Voronoi cells of the Poisson spheres
            out.push_back(s);
        }
        return out;
    }
    const Feature f = featureOf(cell, p.n);
    const uint64_t h = featureKey(f, colouring, p.seed);
    const int span = p.seedsMax - p.seedsMin + 1;
    const int count = p.seedsMin + std::min(span - 1, int(random::uniform(h, kCount, 0) * span));
    const Vec3d offset(random::uniform(h, kPosition, 0), random::uniform(h, kPosition, 1),
                       random::uniform(h, kPosition, 2));
    for (int i = 0; i < count; ++i) {
        // Low-discrepancy positions within the cell (§3), kept off its faces by 5%.
        const Vec3d u = r3(offset, i);
        const Vec3d q = Vec3d(cell[0], cell[1], cell[2]) + u * 0.9 + Vec3d(0.05);
        out.push_back(makeSeed(p, random::hash(h, kKey, uint64_t(i)), q));
    }
    return out;
}

// ---- rocks --------------------------------------------------------------------------------

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

} // namespace

Rock makeRock(const TileParams& p, const Coord& cell, int index, const Colouring& colouring)
{
    const int m = p.voxelsPerCell;
    // The competitors: every seed of the 27 cells around the rock's cell (§3).
    std::vector<Seed> seeds;
    int self = -1;
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
    Rock rock;
    rock.seed = seeds[size_t(self)];
    const double invM = 1.0 / double(m);
    // The nearest seed of voxel v (centre (v + ½)/m cells); ties go to the smaller key.
    // d_k as a quadratic form Q_k = Σ_a w_a e_a e_aᵀ / g_k (w_a = 1/α_a², 6 coefficients),
    // in single precision relative to the rock's cell (every position within 2 cells), the
    // seeds laid out by coefficient so the distance loops vectorise.
    const size_t ns = seeds.size();
    const Vec3d origin(cell[0], cell[1], cell[2]);
    std::vector<float> soa(10 * ns);
    float* px = soa.data();
    float* py = px + ns;
    float* pz = py + ns;
    float* q00 = pz + ns;
    float* q11 = q00 + ns;
    float* q22 = q11 + ns;
    float* q01 = q22 + ns;
    float* q02 = q01 + ns;
    float* q12 = q02 + ns;
    float* dist = q12 + ns;
    for (size_t s = 0; s < ns; ++s) {
        const Seed& k = seeds[s];
        px[s] = float(k.p[0] - origin[0]);
        py[s] = float(k.p[1] - origin[1]);
        pz[s] = float(k.p[2] - origin[2]);
        double q[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) q[i][j] += k.weight[a] * k.frame[a][i] * k.frame[a][j] / k.g;
        q00[s] = float(q[0][0]);
        q11[s] = float(q[1][1]);
        q22[s] = float(q[2][2]);
        q01[s] = float(2 * q[0][1]);
        q02[s] = float(2 * q[0][2]);
        q12[s] = float(2 * q[1][2]);
    }
    auto owner = [&](const Coord& v) {
        const float x = float((v[0] + 0.5) * invM - origin[0]), y = float((v[1] + 0.5) * invM - origin[1]),
                    z = float((v[2] + 0.5) * invM - origin[2]);
        float* __restrict d = dist;
        for (size_t s = 0; s < ns; ++s) {
            const float a = x - px[s], b = y - py[s], c = z - pz[s];
            d[s] = q00[s] * a * a + q11[s] * b * b + q22[s] * c * c + q01[s] * a * b +
                   q02[s] * a * c + q12[s] * b * c;
        }
        int best = 0;
        for (size_t s = 1; s < ns; ++s) {
            if (d[s] < d[best] || (d[s] == d[best] && seeds[s].key < seeds[size_t(best)].key)) {
                best = int(s);
            }
        }
        return int16_t(best);
    };

    // §4 discrete Voronoi cell: flood from the seed's voxel through voxels it owns, within
    // the 27 cells.
    Box<int16_t> label(mul(cell.offsetBy(-1, -1, -1), m), Coord(3 * m), kUnknown);
    const Vec3d& ps = rock.seed.p;
    const Coord start(int(std::floor(ps[0] * m)), int(std::floor(ps[1] * m)),
                      int(std::floor(ps[2] * m)));
    std::vector<Coord> queue;
    std::vector<uint8_t> touches(ns, 0); // the seeds owning a face neighbour of the rock
    for (int i = -1; i <= 1 && queue.empty(); ++i)
        for (int j = -1; j <= 1 && queue.empty(); ++j)
            for (int k = -1; k <= 1 && queue.empty(); ++k) {
                const Coord c = start.offsetBy(i, j, k);
                label[c] = owner(c);
                if (label[c] == self) queue.push_back(c);
            }
    Coord lo(std::numeric_limits<int>::max()), hi(std::numeric_limits<int>::min());
    for (size_t q = 0; q < queue.size(); ++q) {
        const Coord c = queue[q];
        lo = Coord::minComponent(lo, c);
        hi = Coord::maxComponent(hi, c);
        static const int kFace[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        for (const auto& d : kFace) {
            const Coord u = c.offsetBy(d[0], d[1], d[2]);
            if (!label.inside(u)) continue;
            if (label[u] == kUnknown) {
                label[u] = owner(u);
                if (label[u] == self) queue.push_back(u);
            }
            if (label[u] != self) touches[size_t(label[u])] = 1;
        }
    }
    rock.voronoiVoxels = queue.size();
    if (queue.empty()) {
        rock.origin = start;
        rock.dims = Coord(0);
        return rock;
    }

    // §5 contact points: c_kj on [p_k p_j] with d_k(c) = d_j(c) (bisection), kept where the
    // face between the two cells really passes: no third seed nearer, and the discrete
    // cells touch there — two face neighbours among the 8 voxels round c, one of the rock,
    // one of the other cell (near a junction a third cell's voxels can fill the gap). The
    // contact is the middle of the nearest such pair: on the discrete face, so both rocks'
    // surfaces pass through it. Only seeds owning a face neighbour of the rock can qualify
    // (the flood labelled every face neighbour).
    auto labelAt = [&](const Coord& v) { return label.inside(v) ? label[v] : kUnknown; };
    for (int16_t j = 0; j < int16_t(ns); ++j) {
        if (!touches[size_t(j)]) continue;
        const Seed& a = rock.seed;
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
        if (best < std::numeric_limits<double>::max()) rock.contacts.push_back({point, b.key, b.p});
    }

    // §5 erosion over the cell's box grown by one voxel: ρ = 1 in the cell, damped near
    // contacts by ω = min ω_kj (corner cubes) or by the Gaussian resistance (periodic).
    rock.origin = lo.offsetBy(-1, -1, -1);
    rock.dims = (hi - lo).offsetBy(3, 3, 3);
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
    return rock;
}

// ---- tile sets ----------------------------------------------------------------------------

namespace {

struct Job
{
    size_t region;
    Coord cell;
    int index;
    Colouring colouring;
};

} // namespace

TileSet generateTiles(const TileParams& p)
{
    Task task;
    return generateTiles(p, task);
}

TileSet generateTiles(const TileParams& p, Task& task)
{
    p.validate();
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    TileSet set;
    set.params = p;
    std::vector<Job> jobs;
    auto addRegion = [&](Region r, const std::vector<Coord>& cells, Colouring col) {
        const size_t id = set.regions.size();
        set.regions.push_back(std::move(r));
        for (const Coord& c : cells) {
            const int count = int(cellSeeds(p, c, col).size());
            for (int i = 0; i < count; ++i) jobs.push_back({id, c, i, col});
        }
    };
    const int n = p.n;
    if (p.tiling == Tiling::Periodic) {
        std::vector<Coord> cells;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j)
                for (int k = 0; k < n; ++k) cells.emplace_back(i, j, k);
        Region r;
        r.colours = {0};
        addRegion(r, cells, [](int, int, int) { return 0; });
    } else {
        // A context colouring: the feature's vertices as given, every other vertex 0 (the
        // region's rocks do not depend on them).
        auto context = [](std::vector<std::pair<Coord, int>> fixed) -> Colouring {
            return [fixed](int i, int j, int k) {
                for (const auto& f : fixed) if (f.first == Coord(i, j, k)) return f.second;
                return 0;
            };
        };
        // Vertex regions: the 2×2×2 cells around lattice vertex 0.
        for (int c = 0; c < 2; ++c) {
            std::vector<Coord> cells;
            for (int i = -1; i <= 0; ++i)
                for (int j = -1; j <= 0; ++j)
                    for (int k = -1; k <= 0; ++k) cells.emplace_back(i, j, k);
            Region r;
            r.type = 3;
            r.axes = {{1, 1, 1}};
            r.colours = {c};
            addRegion(r, cells, context({{Coord(0), c}}));
        }
        // Edge regions along axis e from vertex 0: 2×2 cells across, n − 2 along.
        for (int e = 0; e < 3; ++e)
            for (int c = 0; c < 4; ++c) {
                const int c0 = c & 1, c1 = (c >> 1) & 1;
                Coord end(0);
                end[e] = 1;
                std::vector<Coord> cells;
                const int u = (e + 1) % 3, v = (e + 2) % 3;
                for (int l = 1; l <= n - 2; ++l)
                    for (int a = -1; a <= 0; ++a)
                        for (int b = -1; b <= 0; ++b) {
                            Coord cc(0);
                            cc[e] = l; cc[u] = a; cc[v] = b;
                            cells.push_back(cc);
                        }
                Region r;
                r.type = 2;
                r.axes = {{1, 1, 1}};
                r.axes[e] = 0;
                r.colours = {c0, c1};
                addRegion(r, cells, context({{Coord(0), c0}, {end, c1}}));
            }
        // Face regions normal to axis a: 2 cells across, (n − 2)² along; colours of the
        // vertices 0, u, v, u + v.
        for (int a = 0; a < 3; ++a)
            for (int c = 0; c < 16; ++c) {
                const int u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
                Coord cu(0), cv(0);
                cu[u] = 1;
                cv[v] = 1;
                const int cols[4] = {c & 1, (c >> 1) & 1, (c >> 2) & 1, (c >> 3) & 1};
                std::vector<Coord> cells;
                for (int i = 1; i <= n - 2; ++i)
                    for (int j = 1; j <= n - 2; ++j)
                        for (int s = -1; s <= 0; ++s) {
                            Coord cc(0);
                            cc[a] = s; cc[u] = i; cc[v] = j;
                            cells.push_back(cc);
                        }
                Region r;
                r.type = 1;
                r.axes = {{0, 0, 0}};
                r.axes[a] = 1;
                r.colours = {cols[0], cols[1], cols[2], cols[3]};
                addRegion(r, cells, context({{Coord(0), cols[0]}, {cu, cols[1]}, {cv, cols[2]},
                                             {cu + cv, cols[3]}}));
            }
        // Centre regions: the (n − 2)³ inner cells of each of the 256 cubes.
        for (int c = 0; c < 256; ++c) {
            std::vector<std::pair<Coord, int>> fixed;
            Region r;
            for (int b = 0; b < 8; ++b) {
                fixed.push_back({Coord((b >> 2) & 1, (b >> 1) & 1, b & 1), (c >> b) & 1});
                r.colours.push_back((c >> b) & 1);
            }
            std::vector<Coord> cells;
            for (int i = 1; i <= n - 2; ++i)
                for (int j = 1; j <= n - 2; ++j)
                    for (int k = 1; k <= n - 2; ++k) cells.emplace_back(i, j, k);
            addRegion(r, cells, context(fixed));
        }
    }
    set.stats.seeds = jobs.size();
    set.stats.regions = set.regions.size();
    set.stats.seedSeconds = std::chrono::duration<double>(Clock::now() - t0).count();

    const auto t1 = Clock::now();
    set.rocks.resize(jobs.size());
    parallelFor(task, jobs.size(), 8, [&](size_t i) {
        set.rocks[i] = makeRock(p, jobs[i].cell, jobs[i].index, jobs[i].colouring);
    });
    set.stats.voronoiSeconds = std::chrono::duration<double>(Clock::now() - t1).count();
    for (size_t i = 0; i < jobs.size(); ++i) {
        set.regions[jobs[i].region].rocks.push_back(i);
        if (set.rocks[i].solidVoxels() > 0) ++set.stats.stones;
        set.stats.contacts += set.rocks[i].contacts.size();
    }
    return set;
}

std::vector<Rock> cubeRocks(const TileParams& p, const Coord& cube, const Colouring& colouring)
{
    p.validate();
    std::vector<std::pair<Coord, int>> jobs;
    for (int i = 0; i < p.n; ++i)
        for (int j = 0; j < p.n; ++j)
            for (int k = 0; k < p.n; ++k) {
                const Coord c = mul(cube, p.n) + Coord(i, j, k);
                const int count = int(cellSeeds(p, c, colouring).size());
                for (int s = 0; s < count; ++s) jobs.push_back({c, s});
            }
    std::vector<Rock> rocks(jobs.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, jobs.size(), 8),
        [&](const tbb::blocked_range<size_t>& r) {
            for (size_t i = r.begin(); i != r.end(); ++i) {
                rocks[i] = makeRock(p, jobs[i].first, jobs[i].second, colouring);
            }
        });
    return rocks;
}

// ---- level sets ---------------------------------------------------------------------------

namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;

// Scratch arrays reused by each thread's rocks (a rock's box is ~10⁴ voxels; allocating
// them per rock cost more than filling them).
struct LevelSetScratch
{
    std::vector<float> r, d2;
    std::vector<Vec3f> cp;
    std::vector<uint8_t> done;
    std::vector<int32_t> front, next;
};

// The leaves of a rock's level set (see rockLevelSet), inactive voxels at ±background by
// side: ready to be added to any tree. Every inside voxel lies in a leaf, so a tree made of
// such leaves needs no sign flood fill.
std::vector<LeafT*> rockLeaves(const Rock& rock, double voxelSize, const Coord& offset,
                               double halfWidth)
{
    std::vector<LeafT*> out;
    if (rock.rho.empty()) return out;
    thread_local LevelSetScratch scratch;
    LevelSetScratch& sc = scratch;
    const float bg = float(halfWidth * voxelSize);
    // The trilinear surface r = 2ρ − 1 = 0 is sampled where it crosses the grid's edges, and
    // each voxel's nearest crossing is carried outward layer by layer over the band (each
    // layer offers its crossings to its 26 neighbours; a voxel keeps the nearest offered):
    // distances to the sampled surface. Dense arrays over the rock's box padded by the band;
    // cp holds the vector from a voxel to its crossing, d2 its squared length.
    const int pad = int(std::ceil(halfWidth)) + 1;
    const int nx = rock.dims[0] + 2 * pad, ny = rock.dims[1] + 2 * pad, nz = rock.dims[2] + 2 * pad;
    const size_t total = size_t(nx) * ny * nz;
    const int sx = ny * nz, sy = nz;
    constexpr float kFar = std::numeric_limits<float>::max();
    sc.r.assign(total, -0.5f);
    sc.d2.assign(total, kFar);
    sc.cp.resize(total);
    sc.done.assign(total, 0);
    // Raw pointers: stores through uint8_t may alias anything, so through the vectors every
    // store to done would reload every array's address.
    float* const r = sc.r.data();
    float* const d2 = sc.d2.data();
    Vec3f* const cp = sc.cp.data();
    uint8_t* const done = sc.done.data();
    for (int x = 0; x < rock.dims[0]; ++x)
        for (int y = 0; y < rock.dims[1]; ++y) {
            const float* src = rock.rho.data() + size_t((x * rock.dims[1] + y) * rock.dims[2]);
            float* dst = r + size_t((x + pad) * sx + (y + pad) * sy + pad);
            for (int z = 0; z < rock.dims[2]; ++z) dst[z] = src[z] - 0.5f;
        }
    std::vector<int32_t>& front = sc.front;
    std::vector<int32_t>& next = sc.next;
    front.clear();
    // Crossings lie within the rock's box grown by one voxel. Each is offered to the 18
    // voxels round its edge (the edge's ends and their 8 neighbours across it), which takes
    // the nearest crossing of every voxel near the surface exactly.
    const int stride[3] = {sx, sy, 1};
    for (int x = pad - 1; x < pad + rock.dims[0]; ++x)
        for (int y = pad - 1; y < pad + rock.dims[1]; ++y)
            for (int z = pad - 1; z < pad + rock.dims[2]; ++z) {
                const int i = x * sx + y * sy + z;
                const float rc = r[i];
                for (int a = 0; a < 3; ++a) {
                    const float rj = r[i + stride[a]];
                    if ((rc > 0) == (rj > 0)) continue;
                    const float t = rc / (rc - rj);
                    const int b = (a + 1) % 3, c = (a + 2) % 3;
                    for (int side = 0; side < 2; ++side)
                        for (int db = -1; db <= 1; ++db)
                            for (int dc = -1; dc <= 1; ++dc) {
                                const int k = i + side * stride[a] + db * stride[b] + dc * stride[c];
                                Vec3f v;
                                v[a] = side ? t - 1.0f : t;
                                v[b] = float(-db);
                                v[c] = float(-dc);
                                const float dd = v.lengthSqr();
                                if (dd < d2[k]) {
                                    d2[k] = dd;
                                    cp[k] = v;
                                }
                                if (!done[k]) {
                                    done[k] = 1;
                                    front.push_back(k);
                                }
                            }
                }
            }
    int nb[26];
    Vec3f nbOffset[26];
    {
        int q = 0;
        for (int i = -1; i <= 1; ++i)
            for (int j = -1; j <= 1; ++j)
                for (int k = -1; k <= 1; ++k) {
                    if (!(i || j || k)) continue;
                    nb[q] = i * sx + j * sy + k;
                    nbOffset[q++] = Vec3f(float(i), float(j), float(k));
                }
    }
    // Each layer pushes its crossings to the not yet finished neighbours; the next layer is
    // the set of voxels reached (in the order first reached: deterministic). The first
    // layer lies within a voxel of the crossings' edges, so pad − 2 more reach every voxel
    // nearer than the half width, and the padding keeps their neighbours inside the box.
    for (int layer = 0; layer < pad - 2 && !front.empty(); ++layer) {
        next.clear();
        for (const int c : front) {
            const Vec3f vc = cp[c];
            for (int q = 0; q < 26; ++q) {
                const int u = c + nb[q];
                const uint8_t state = done[u];
                const Vec3f v = vc - nbOffset[q];
                const float dd = v.lengthSqr();
                if (state == 0) {
                    done[u] = 2;
                    next.push_back(u);
                    d2[u] = dd;
                    cp[u] = v;
                } else if (dd < d2[u]) {
                    d2[u] = dd;
                    cp[u] = v;
                }
            }
        }
        for (const int u : next) done[u] = 1;
        front.swap(next);
    }
    // Straight into leaves: band voxels active, the rest ±background by side.
    const float band2 = float(halfWidth * halfWidth);
    const float scale = float(voxelSize);
    const Coord base = rock.origin.offsetBy(-pad, -pad, -pad) + offset;
    const Coord last = base.offsetBy(nx - 1, ny - 1, nz - 1);
    const Coord first = base & ~7;
    for (int lx = first[0]; lx <= last[0]; lx += 8)
        for (int ly = first[1]; ly <= last[1]; ly += 8)
            for (int lz = first[2]; lz <= last[2]; lz += 8) {
                LeafT* leaf = nullptr;
                float* values = nullptr;
                const int z0 = std::max(lz, base[2]), z1 = std::min(lz + 8, last[2] + 1);
                for (int x = std::max(lx, base[0]); x < std::min(lx + 8, last[0] + 1); ++x)
                    for (int y = std::max(ly, base[1]); y < std::min(ly + 8, last[1] + 1); ++y) {
                        const int row = (x - base[0]) * sx + (y - base[1]) * sy - base[2];
                        const openvdb::Index rowOffset = ((x & 7) << 6) | ((y & 7) << 3);
                        for (int z = z0; z < z1; ++z) {
                            const int i = row + z;
                            const bool in = r[i] > 0;
                            const bool band = d2[i] < band2;
                            if (!band && !in) continue;
                            if (!leaf) {
                                leaf = new LeafT(Coord(lx, ly, lz), bg);
                                values = leaf->buffer().data();
                            }
                            const openvdb::Index n = rowOffset | openvdb::Index(z & 7);
                            if (band) {
                                const float d = std::sqrt(d2[i]) * scale;
                                values[n] = in ? -d : d;
                                leaf->getValueMask().setOn(n);
                            } else {
                                values[n] = -bg;
                            }
                        }
                    }
                if (leaf) out.push_back(leaf);
            }
    return out;
}

} // namespace

std::vector<LeafT*> rockLeavesShifted(const Rock& rock, double voxelSize, const Coord& offset,
                                      double halfWidth)
{
    return rockLeaves(rock, voxelSize, offset, halfWidth);
}

openvdb::FloatGrid::Ptr rockLevelSet(const Rock& rock, double voxelSize, const Coord& offset,
                                     double halfWidth)
{
    auto grid = openvdb::FloatGrid::create(float(halfWidth * voxelSize));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(voxelSize));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    grid->setName("surface");
    // (No flood fill: every inside voxel is in a leaf.)
    for (LeafT* leaf : rockLeaves(rock, voxelSize, offset, halfWidth)) grid->tree().addLeaf(leaf);
    return grid;
}

namespace {

// Atlas slots: 8-aligned boxes large enough for any rock's box (3 cells) padded by @a pad
// voxels, so no two rocks share a leaf. Rock i's canonical voxel v sits at v + offset_i.
std::vector<Coord> atlasOffsets(const TileSet& set, int pad)
{
    const int slot = ((3 * set.params.voxelsPerCell + 2 * pad + 2) + 7) / 8 * 8;
    const size_t count = set.rocks.size();
    const int side = std::max(1, int(std::ceil(std::cbrt(double(std::max<size_t>(count, 1))))));
    std::vector<Coord> offsets(count);
    for (size_t i = 0; i < count; ++i) {
        const Coord s(int(i % size_t(side)), int((i / size_t(side)) % size_t(side)),
                      int(i / size_t(side * side)));
        offsets[i] = mul(s, slot) - set.rocks[i].origin.offsetBy(-pad, -pad, -pad);
    }
    return offsets;
}

constexpr int kRhoPad = 1;

} // namespace

openvdb::FloatGrid::Ptr libraryGrid(const TileSet& set, double halfWidth, double* seconds)
{
    Task task;
    return libraryGrid(set, task, halfWidth, seconds);
}

openvdb::FloatGrid::Ptr libraryGrid(const TileSet& set, Task& task, double halfWidth,
                                    double* seconds)
{
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    const double dx = set.params.voxelSize();
    const int pad = int(std::ceil(halfWidth)) + 1;
    const std::vector<Coord> offsets = atlasOffsets(set, pad);
    const size_t count = set.rocks.size();
    std::vector<std::vector<LeafT*>> leaves(count);
    try {
        parallelFor(task, count, 16, [&](size_t i) {
            leaves[i] = rockLeaves(set.rocks[i], dx, offsets[i], halfWidth);
        });
    } catch (...) {
        for (auto& list : leaves)
            for (LeafT* leaf : list) delete leaf;
        throw;
    }
    auto library = openvdb::FloatGrid::create(float(halfWidth * dx));
    library->setTransform(openvdb::math::Transform::createLinearTransform(dx));
    library->setGridClass(openvdb::GRID_LEVEL_SET);
    library->setName("library");
    for (auto& list : leaves)
        for (LeafT* leaf : list) library->tree().addLeaf(leaf);
    nlohmann::json slots = nlohmann::json::array();
    for (size_t i = 0; i < count; ++i) slots.push_back({offsets[i][0], offsets[i][1], offsets[i][2]});
    library->insertMeta("rockvdb:library_offsets", openvdb::StringMetadata(slots.dump()));
    if (seconds) *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return library;
}

openvdb::FloatGrid::Ptr tileGrid(const TileSet& set)
{
    Task task;
    return tileGrid(set, task);
}

openvdb::FloatGrid::Ptr tileGrid(const TileSet& set, Task& task)
{
    const TileParams& p = set.params;
    const double dx = p.voxelSize();
    const std::vector<Coord> offsets = atlasOffsets(set, kRhoPad);
    auto rho = openvdb::FloatGrid::create(0.0f);
    rho->setTransform(openvdb::math::Transform::createLinearTransform(dx));
    rho->setGridClass(openvdb::GRID_FOG_VOLUME);
    rho->setName("rho");
    rho->setSaveFloatAsHalf(true);
    auto acc = rho->getAccessor();
    nlohmann::json rocks = nlohmann::json::array();
    for (size_t i = 0; i < set.rocks.size(); ++i) {
        if (i % 256 == 0) task.step(double(i) / double(set.rocks.size()));
        const Rock& r = set.rocks[i];
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    const float v = r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)];
                    if (v > 0) acc.setValue(r.origin.offsetBy(x, y, z) + offsets[i], v);
                }
        char key[17];
        std::snprintf(key, sizeof key, "%016llx", static_cast<unsigned long long>(r.seed.key));
        rocks.push_back({{"key", key},
                         {"seed", {r.seed.p[0], r.seed.p[1], r.seed.p[2]}},
                         {"offset", {offsets[i][0], offsets[i][1], offsets[i][2]}},
                         {"origin", {r.origin[0], r.origin[1], r.origin[2]}},
                         {"dims", {r.dims[0], r.dims[1], r.dims[2]}},
                         {"solid", r.solidVoxels()},
                         {"voronoi", r.voronoiVoxels},
                         {"contacts", r.contacts.size()}});
    }
    nlohmann::json regions = nlohmann::json::array();
    for (const Region& g : set.regions) {
        regions.push_back({{"type", g.type}, {"axes", g.axes}, {"colours", g.colours},
                           {"rocks", g.rocks}});
    }
    const TileStats& st = set.stats;
    nlohmann::json meta = {
        {"format", 1},
        {"params", p.toJson()},
        {"voxel_size", dx},
        {"stats", {{"stones", st.stones}, {"regions", st.regions}, {"seeds", st.seeds},
                   {"contacts", st.contacts}}},
        {"regions", regions},
        {"rocks", rocks}};
    rho->insertMeta("rockvdb:tiles", openvdb::StringMetadata(meta.dump()));
    return rho;
}

TileSet tilesFromGrid(const openvdb::FloatGrid& rho)
{
    const auto meta = rho.getMetadata<openvdb::StringMetadata>("rockvdb:tiles");
    if (!meta) fail<ValueError>("rockpile: grid '", rho.getName(), "' holds no tile set (no rockvdb:tiles metadata)");
    const nlohmann::json j = nlohmann::json::parse(meta->value(), nullptr, false);
    if (j.is_discarded() || !j.contains("format") || j["format"] != 1) {
        fail<ValueError>("rockpile: unreadable tile set description (format 1 expected)");
    }
    TileSet set;
    // Format 1 files written before the parameter tables spelt keys with '_'.
    nlohmann::json params = nlohmann::json::object();
    for (auto it = j.at("params").begin(); it != j.at("params").end(); ++it) {
        std::string key = it.key();
        std::replace(key.begin(), key.end(), '_', '-');
        params[key] = it.value();
    }
    set.params = TileParams::fromJson(params);
    auto acc = rho.getConstAccessor();
    for (const auto& rj : j.at("rocks")) {
        Rock r;
        r.seed.key = std::stoull(rj.at("key").get<std::string>(), nullptr, 16);
        for (int a = 0; a < 3; ++a) {
            r.seed.p[a] = rj.at("seed").at(a).get<double>();
            r.origin[a] = rj.at("origin").at(a).get<int>();
            r.dims[a] = rj.at("dims").at(a).get<int>();
        }
        if (r.dims[0] < 0 || r.dims[1] < 0 || r.dims[2] < 0 ||
            double(r.dims[0]) * r.dims[1] * r.dims[2] > 1e7) {
            fail<ValueError>("rockpile: tile set rock box out of range");
        }
        const Coord off(rj.at("offset").at(0).get<int>(), rj.at("offset").at(1).get<int>(),
                        rj.at("offset").at(2).get<int>());
        r.voronoiVoxels = rj.value("voronoi", size_t(0));
        r.rho.resize(size_t(r.dims[0]) * r.dims[1] * r.dims[2]);
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)] =
                        acc.getValue(r.origin.offsetBy(x, y, z) + off);
                }
        set.rocks.push_back(std::move(r));
    }
    for (const auto& gj : j.at("regions")) {
        Region g;
        g.type = gj.at("type").get<int>();
        g.axes = gj.at("axes").get<std::array<int, 3>>();
        g.colours = gj.at("colours").get<std::vector<int>>();
        g.rocks = gj.at("rocks").get<std::vector<size_t>>();
        for (size_t i : g.rocks) {
            if (i >= set.rocks.size()) fail<ValueError>("rockpile: tile set region names rock ", i, " of ", set.rocks.size());
        }
        set.regions.push_back(std::move(g));
    }
    const auto& st = j.at("stats");
    set.stats.stones = st.value("stones", size_t(0));
    set.stats.regions = set.regions.size();
    set.stats.seeds = set.rocks.size();
    set.stats.contacts = st.value("contacts", size_t(0));
    return set;
}

} // namespace rockpile
} // namespace rockvdb
