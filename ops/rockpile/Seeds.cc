// SPDX-License-Identifier: Apache-2.0
// Rock tiles: the seeds of a cell (arches-material-stacks-terrain.txt §5 periodic Poisson
// seeds; rock-piles §3 corner cubes: a cell's seeds depend only on the feature owning it).
#include <rockvdb/rockpile/RockTiles.h>

#include <rockvdb/core/GridUtil.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/Sampling.h>

#include <algorithm>
#include <cmath>
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

Seed makeSeed(const RockTileParams& p, uint64_t h, const Vec3d& position)
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
const std::vector<std::vector<Vec3d>>& periodicSeeds(const RockTileParams& p)
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

std::vector<Seed> cellSeeds(const RockTileParams& p, const Coord& cell, const Colouring& colouring)
{
    std::vector<Seed> out;
    if (p.tiling == Tiling::Periodic) {
        const Coord cube(floorDiv(cell[0], p.n), floorDiv(cell[1], p.n), floorDiv(cell[2], p.n));
        const Coord l = cell - scaled(cube, p.n);
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

} // namespace rockpile
} // namespace rockvdb
