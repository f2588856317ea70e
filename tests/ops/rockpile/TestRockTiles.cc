// SPDX-License-Identifier: Apache-2.0
// Rock tiles (issue 6, aperiodic-rock-piles.txt §3–§5): corner-cube consistency across
// compatible neighbours, contacts on both rocks' surfaces, no voxel in two rocks, erosion,
// anisotropic (flat, not needle) rocks, determinism across threads, level-set distances and
// the library, and bad parameters.
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/rockpile/RockTiles.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <openvdb/tools/Interpolation.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <map>

using namespace rockvdb;
using namespace rockvdb::rockpile;
using openvdb::Coord;

namespace {

RockTileParams smallTiles()
{
    RockTileParams p;
    p.n = 5;
    p.voxelsPerCell = 6;
    p.seed = 3;
    return p;
}

// Random 2-colourings of the lattice.
Colouring randomColouring(uint64_t seed)
{
    return [seed](int i, int j, int k) { return int(random::hashCoord(seed, 77, i, j, k) & 1); };
}

bool sameRock(const Rock& a, const Rock& b)
{
    return a.seed.key == b.seed.key && a.origin == b.origin && a.dims == b.dims && a.rho == b.rho;
}

// The principal extents of a rock's solid voxels, largest first (square roots of the
// covariance eigenvalues); zeros for rocks too small to measure.
std::array<double, 3> rockExtents(const Rock& r)
{
    std::vector<openvdb::Vec3d> pts;
    for (int x = 0; x < r.dims[0]; ++x)
        for (int y = 0; y < r.dims[1]; ++y)
            for (int z = 0; z < r.dims[2]; ++z) {
                if (r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)] > 0.5f) pts.emplace_back(x, y, z);
            }
    if (pts.size() < 20) return {{0, 0, 0}};
    openvdb::Vec3d mean(0.0);
    for (auto& q : pts) mean += q;
    mean /= double(pts.size());
    openvdb::math::Mat3d cov(openvdb::math::Mat3d::zero());
    for (auto& q : pts) {
        const auto d = q - mean;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) cov(i, j) += d[i] * d[j];
    }
    openvdb::Vec3d ev;
    openvdb::math::Mat3d vecs;
    openvdb::math::diagonalizeSymmetricMatrix(cov, vecs, ev);
    std::array<double, 3> e{{std::sqrt(std::max(ev[0], 0.0)), std::sqrt(std::max(ev[1], 0.0)),
                             std::sqrt(std::max(ev[2], 0.0))}};
    std::sort(e.begin(), e.end(), std::greater<double>());
    return e;
}

} // namespace

TEST(RockTiles, RocksStraddlingASharedFaceAreTheSameFromEitherCube)
{
    initialize();
    const RockTileParams p = smallTiles();
    const int n = p.n;
    // Cube (0,0,0) under colouring A and its +x neighbour (1,0,0) under colouring B: they agree
    // on the 4 vertices of the shared face x = 1 and nowhere else is B forced to agree.
    const Colouring a = randomColouring(11);
    const Colouring b = [a](int i, int j, int k) {
        if (i == 1 && (j == 0 || j == 1) && (k == 0 || k == 1)) return a(i, j, k);
        return 1 - a(i, j, k);
    };
    size_t compared = 0, straddling = 0;
    const int m = p.voxelsPerCell;
    for (int x : {n - 1, n}) // the cells on both sides of the face
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k) {
                const Coord c(x, j, k);
                const auto seedsA = cellSeeds(p, c, a);
                ASSERT_EQ(seedsA.size(), cellSeeds(p, c, b).size());
                for (int s = 0; s < int(seedsA.size()); ++s) {
                    const Rock ra = makeRock(p, c, s, a), rb = makeRock(p, c, s, b);
                    EXPECT_TRUE(sameRock(ra, rb)) << "cell " << c << " seed " << s;
                    ++compared;
                    // Solid voxels on both sides of the face plane x = n·m voxels.
                    bool left = false, right = false;
                    for (int vx = 0; vx < ra.dims[0]; ++vx)
                        for (int vy = 0; vy < ra.dims[1]; ++vy)
                            for (int vz = 0; vz < ra.dims[2]; ++vz) {
                                if (ra.rho[size_t((vx * ra.dims[1] + vy) * ra.dims[2] + vz)] <= 0.5f) continue;
                                (ra.origin[0] + vx < n * m ? left : right) = true;
                            }
                    if (left && right) ++straddling;
                }
            }
    EXPECT_GT(straddling, size_t(10)) << "of " << compared;
    // The test can fail: a centre rock of cube (0,0,0) changes with the colours B flips.
    const Coord centre(2, 2, 2);
    EXPECT_FALSE(sameRock(makeRock(p, centre, 0, a), makeRock(p, centre, 0, b)));
}

TEST(RockTiles, ContactsLieOnBothRocksAndNoVoxelIsInTwoRocks)
{
    initialize();
    const RockTileParams p = smallTiles();
    const Colouring col = randomColouring(5);
    const auto rocks = cubeRocks(p, Coord(0), col);
    // Keys name rock content (a region recurs); the seed position names the copy.
    std::map<std::pair<uint64_t, std::array<double, 3>>, const Rock*> bySeed;
    auto id = [](uint64_t key, const openvdb::Vec3d& q) {
        return std::make_pair(key, std::array<double, 3>{{q[0], q[1], q[2]}});
    };
    for (const Rock& r : rocks) bySeed[id(r.seed.key, r.seed.p)] = &r;
    const double dx = p.voxelSize();
    size_t checked = 0, oneSided = 0;
    double worstContact = 0;
    for (const Rock& r : rocks) {
        const auto ls = rockLevelSet(r, dx);
        for (const Contact& c : r.contacts) {
            auto it = bySeed.find(id(c.other, c.otherSeed));
            if (it == bySeed.end()) continue; // the other rock's seed is in another cube
            // Kept contacts are mutual (each rock finds the face from its own 27 cells),
            // but for the rare pair a seed outside one of the neighbourhoods decides.
            const auto& back = it->second->contacts;
            if (std::none_of(back.begin(), back.end(),
                             [&](const Contact& o) { return o.otherSeed == r.seed.p; })) {
                ++oneSided;
                continue;
            }
            const auto other = rockLevelSet(*it->second, dx);
            const openvdb::Vec3d q(c.point);
            const double da = openvdb::tools::BoxSampler::sample(ls->tree(), q) / dx;
            const double db = openvdb::tools::BoxSampler::sample(other->tree(), q) / dx;
            worstContact = std::max({worstContact, std::abs(da), std::abs(db)});
            EXPECT_LE(std::abs(da), 1.0) << "contact " << q;
            EXPECT_LE(std::abs(db), 1.0) << "contact " << q;
            ++checked;
        }
    }
    EXPECT_GT(checked, rocks.size());
    // The issue asks for one voxel; a contact sits on the discrete face between the two
    // rocks, where both surfaces pass.
    EXPECT_LT(worstContact, 0.1);
    // A contact is one-sided only when a seed outside one rock's 27 cells decides it.
    EXPECT_LT(oneSided * 100, checked);
    std::map<Coord, int> owners;
    for (const Rock& r : rocks)
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    if (r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)] > 0.5f) {
                        ++owners[r.origin.offsetBy(x, y, z)];
                    }
                }
    size_t shared = 0;
    for (const auto& o : owners) shared += o.second > 1;
    EXPECT_EQ(shared, size_t(0)) << "of " << owners.size() << " voxels";
}

TEST(RockTiles, ErosionRemovesVolumeButKeepsContacts)
{
    initialize();
    RockTileParams p = smallTiles();
    const Colouring col = randomColouring(9);
    for (int steps : {0, 6}) {
        p.erosionSteps = steps;
        const auto rocks = cubeRocks(p, Coord(0), col);
        size_t below = 0, voronoi = 0, solid = 0;
        for (const Rock& r : rocks) {
            voronoi += r.voronoiVoxels;
            solid += r.solidVoxels();
            below += r.solidVoxels() < r.voronoiVoxels;
        }
        if (steps == 0) {
            EXPECT_EQ(solid, voronoi); // the bare Voronoi cells
        } else {
            EXPECT_EQ(below, rocks.size()) << "every rock loses volume";
            EXPECT_LT(double(solid), 0.85 * double(voronoi));
            EXPECT_GT(double(solid), 0.3 * double(voronoi));
        }
    }
    // Periodic tiles (arches §5): the Gaussian resistance of width r (the Poisson disk
    // radius, half the seed spacing) still lets the rocks erode: ~0.79 of the cells remain
    // (with r the full spacing, 0.97: the cells' voxel staircase stays).
    RockTileParams q = smallTiles();
    q.tiling = Tiling::Periodic;
    q.n = 4;
    q.voxelsPerCell = 10;
    const TileSet periodic = generateTiles(q);
    size_t voronoi = 0, solid = 0, below = 0;
    for (const Rock& r : periodic.rocks) {
        voronoi += r.voronoiVoxels;
        solid += r.solidVoxels();
        below += r.solidVoxels() < r.voronoiVoxels;
    }
    EXPECT_EQ(below, periodic.rocks.size()) << "every rock loses volume";
    EXPECT_LT(double(solid), 0.88 * double(voronoi));
    EXPECT_GT(double(solid), 0.5 * double(voronoi));
}

TEST(RockTiles, AnisotropicDistanceMakesFlatRocks)
{
    initialize();
    RockTileParams p = smallTiles();
    p.voxelsPerCell = 10;
    p.anisotropyJitter = 0;
    const Colouring col = randomColouring(2);
    // Median thickness / width (smallest over largest extent) and middle / width: flat
    // rocks have a small first and a large second, needles small both, round rocks neither.
    auto shape = [&](std::array<double, 3> aniso) {
        p.anisotropy = aniso;
        std::vector<double> thin, mid;
        for (const Rock& r : cubeRocks(p, Coord(0), col)) {
            const auto e = rockExtents(r);
            if (e[0] <= 0) continue;
            thin.push_back(e[2] / e[0]);
            mid.push_back(e[1] / e[0]);
        }
        auto median = [](std::vector<double> v) {
            std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
            return v[v.size() / 2];
        };
        return std::make_pair(median(thin), median(mid));
    };
    // §4, Figure 13: α = β = 5, γ = 1 gives flat rocks.
    const auto flat = shape({{5, 5, 1}}), round = shape({{1, 1, 1}}), needle = shape({{1, 1, 5}});
    EXPECT_LT(flat.first, 0.5);
    EXPECT_GT(flat.second, 0.6);
    EXPECT_GT(round.first, 0.5);
    EXPECT_LT(needle.second, 0.6);
}

TEST(RockTiles, DeterministicAcrossThreadCounts)
{
    initialize();
    RockTileParams p = smallTiles();
    p.n = 4;
    TileSet one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = generateTiles(p);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = generateTiles(p);
    }
    ASSERT_EQ(one.rocks.size(), two.rocks.size());
    for (size_t i = 0; i < one.rocks.size(); ++i) EXPECT_TRUE(sameRock(one.rocks[i], two.rocks[i]));
    // 2 + 12 + 48 + 256 regions, and as many rocks as seeds.
    EXPECT_EQ(one.regions.size(), size_t(318));
    EXPECT_EQ(one.rocks.size(), one.stats.seeds);
}

TEST(RockTiles, LevelSetsAreDistancesToTheSampledSurface)
{
    initialize();
    const RockTileParams p = smallTiles();
    const auto rocks = cubeRocks(p, Coord(0), randomColouring(4));
    const double dx = p.voxelSize(), hw = 3.0;
    // The surface r = ρ − ½ = 0 sampled where it crosses the voxel edges, found here
    // independently; every band voxel's |φ| must be its distance to the nearest crossing.
    double worst = 0, sum = 0;
    size_t band = 0, missing = 0, big = 0;
    for (size_t i = 0; i < rocks.size(); i += 4) {
        const Rock& r = rocks[i];
        std::vector<openvdb::Vec3d> crossings;
        for (int x = -1; x <= r.dims[0]; ++x)
            for (int y = -1; y <= r.dims[1]; ++y)
                for (int z = -1; z <= r.dims[2]; ++z) {
                    const Coord c = r.origin.offsetBy(x, y, z);
                    const double a = r.at(c) - 0.5;
                    for (int axis = 0; axis < 3; ++axis) {
                        Coord d = c;
                        d[axis] += 1;
                        const double b = r.at(d) - 0.5;
                        if ((a > 0) == (b > 0)) continue;
                        openvdb::Vec3d q(c[0], c[1], c[2]);
                        q[axis] += a / (a - b);
                        crossings.push_back(q);
                    }
                }
        ASSERT_FALSE(crossings.empty());
        const auto ls = rockLevelSet(r, dx, Coord(0), hw);
        EXPECT_EQ(ls->getGridClass(), openvdb::GRID_LEVEL_SET);
        const auto acc = ls->getConstAccessor();
        // Every voxel of the rock's box grown by the band: sign from ρ, distance if in band.
        for (int x = -4; x < r.dims[0] + 4; ++x)
            for (int y = -4; y < r.dims[1] + 4; ++y)
                for (int z = -4; z < r.dims[2] + 4; ++z) {
                    const Coord c = r.origin.offsetBy(x, y, z);
                    double exact = 1e30;
                    for (const auto& q : crossings) exact = std::min(exact, (q - c.asVec3d()).lengthSqr());
                    exact = std::sqrt(exact);
                    const float phi = acc.getValue(c);
                    ASSERT_EQ(phi < 0, r.at(c) > 0.5f) << c;
                    if (exact < hw - 0.25) missing += !acc.isValueOn(c);
                    if (!acc.isValueOn(c)) continue;
                    const double err = std::abs(std::abs(phi) / dx - exact);
                    worst = std::max(worst, err);
                    sum += err;
                    big += err > 0.05;
                    ++band;
                }
    }
    EXPECT_GT(band, size_t(10000));
    EXPECT_EQ(missing, size_t(0)) << "band voxels left inactive";
    EXPECT_LT(sum / double(band), 0.002) << "mean error, voxels";
    EXPECT_LT(double(big), 0.002 * double(band)) << "voxels off by more than 0.05 voxel";
    EXPECT_LT(worst, 0.25) << "max error, voxels";

    // The library holds each rock's level set bit for bit, at the slot its metadata names.
    RockTileParams q = smallTiles();
    q.n = 4;
    const TileSet set = generateTiles(q);
    const auto library = libraryGrid(set, hw);
    const auto slots = nlohmann::json::parse(
        library->metaValue<std::string>("rockvdb:library_offsets"));
    ASSERT_EQ(slots.size(), set.rocks.size());
    const auto lacc = library->getConstAccessor();
    size_t active = 0;
    for (size_t i = 0; i < set.rocks.size(); i += 7) {
        const Coord offset(slots[i][0].get<int>(), slots[i][1].get<int>(), slots[i][2].get<int>());
        const auto own = rockLevelSet(set.rocks[i], q.voxelSize(), offset, hw);
        for (auto it = own->cbeginValueOn(); it; ++it) {
            ASSERT_EQ(lacc.getValue(it.getCoord()), *it) << "rock " << i;
            ASSERT_TRUE(lacc.isValueOn(it.getCoord()));
            ++active;
        }
    }
    EXPECT_GT(active, size_t(0));
    // And nothing else: its active voxels are exactly those of all the rocks' level sets.
    size_t all = 0;
    for (size_t i = 0; i < set.rocks.size(); ++i) {
        all += rockLevelSet(set.rocks[i], q.voxelSize(), Coord(0), hw)->activeVoxelCount();
    }
    EXPECT_EQ(library->activeVoxelCount(), all);
}

TEST(RockTiles, BadParametersAreClearErrors)
{
    auto message = [](RockTileParams p) {
        try {
            p.validate();
        } catch (const ValueError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    RockTileParams p;
    p.n = 1;
    EXPECT_EQ(message(p), "rockpile: n must be in [3, 64] (got 1)");
    p = RockTileParams();
    p.seedsMin = 0;
    EXPECT_EQ(message(p), "rockpile: seeds-per-cell must be in [1, 64] (got 0)");
    p = RockTileParams();
    p.contactInner = 0.5;
    p.contactOuter = 0.2;
    EXPECT_NE(message(p).find("a < b"), std::string::npos);
    p = RockTileParams();
    p.gMax = 0.5;
    EXPECT_EQ(message(p), "rockpile: g-max must be in [1, 16] (got 0.5)");
}

// ---- piles (§6) ---------------------------------------------------------------------------

#include <rockvdb/core/Primitives.h>
#include <rockvdb/rockpile/RockPile.h>

namespace {

// Occupancy (inside some rock) of the horizontal slice z = @a k, over [0, size)² voxels.
std::vector<float> slice(const openvdb::FloatGrid& g, int k, int size)
{
    std::vector<float> s(size_t(size) * size);
    auto acc = g.getConstAccessor();
    for (int i = 0; i < size; ++i)
        for (int j = 0; j < size; ++j) s[size_t(i * size + j)] = acc.getValue(Coord(i, j, k)) < 0 ? 1.f : 0.f;
    return s;
}

// Normalised correlation of the slice with itself shifted by @a lag voxels along x, away
// from the support's sides by @a margin voxels (rocks there are cut by the anchor test).
double correlation(const std::vector<float>& s, int size, int lag, int margin)
{
    double sa = 0, sb = 0, sab = 0, saa = 0, sbb = 0;
    size_t n = 0;
    for (int i = margin; i + lag < size - margin; ++i)
        for (int j = margin; j < size - margin; ++j) {
            const double a = s[size_t(i * size + j)], b = s[size_t((i + lag) * size + j)];
            sa += a; sb += b; sab += a * b; saa += a * a; sbb += b * b; ++n;
        }
    const double cov = sab / n - sa / n * sb / n;
    return cov / std::sqrt((saa / n - sa * sa / n / n) * (sbb / n - sb * sb / n / n));
}

} // namespace

TEST(RockPile, AnchorsAreInsideTheSupport)
{
    initialize();
    RockTileParams p = smallTiles();
    const TileSet set = generateTiles(p);
    const auto support = sphere(Vec3d(0.3, -0.2, 0.1), 1.3);
    PileParams pp;
    PileStats st;
    const Pile pile = buildPile(set, selectRocks(set, *support, pp, &st), pp);
    ASSERT_GT(pile.instances.size(), size_t(100));
    // Independently of the selection: the rocks' inside voxels, read off the output grids.
    size_t inside = 0, total = 0;
    for (auto it = pile.rockId->cbeginValueOn(); it; ++it) {
        if (pile.surface->tree().getValue(it.getCoord()) >= 0) continue;
        ++total;
        inside += support->eval(pile.surface->indexToWorld(it.getCoord())) < 0;
    }
    EXPECT_GT(double(inside), 0.9 * double(total)) << inside << " of " << total;
    // Every instance's id names a rock whose inside voxels exist.
    std::vector<size_t> perInstance(pile.instances.size(), 0);
    for (auto it = pile.rockId->cbeginValueOn(); it; ++it) ++perInstance[size_t(*it)];
    EXPECT_EQ(size_t(std::count(perInstance.begin(), perInstance.end(), size_t(0))), size_t(0));
    EXPECT_GT(st.droppedDeep, size_t(0)); // a 1.3 m ball of 0.2 m rocks has a deep core
}

TEST(RockPile, PlacedRocksNeverShareAVoxel)
{
    // Rocks in contact, not in each other (rock piles §6, arches §5): a support spanning many
    // lattice vertices, edges and faces (where a rock straddling a cube face is offered by
    // several features and must be placed once) - no solid voxel (rho > 1/2) of one placed
    // rock is a solid voxel of another.
    initialize();
    const TileSet set = generateTiles(smallTiles());
    const auto support = box(Vec3d(0.1, -0.2, 0.0), Vec3d(1.6, 1.3, 0.7));
    PileParams pp;
    pp.dropDeep = false; // the core's rocks too
    const auto instances = selectRocks(set, *support, pp);
    ASSERT_GT(instances.size(), size_t(200));
    std::map<Coord, int> owners;
    for (const Instance& in : instances) {
        const Rock& r = set.rocks[in.rock];
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    if (r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)] > 0.5f) {
                        ++owners[r.origin.offsetBy(x, y, z) + in.shift];
                    }
                }
    }
    size_t shared = 0;
    for (const auto& o : owners) shared += o.second > 1;
    EXPECT_EQ(shared, size_t(0)) << "of " << owners.size() << " voxels";
}

TEST(RockPile, PeriodicTilingRepeatsAndAperiodicDoesNot)
{
    initialize();
    auto lagCorrelation = [](RockTileParams p) {
        p.voxelsPerCell = 5;
        const TileSet set = generateTiles(p);
        const int span = p.n * p.voxelsPerCell;
        // A slab 4 cubes wide, one cube thick.
        const auto slab = box(Vec3d(2.0, 2.0, 0.5) * p.cubeSize, Vec3d(2.0, 2.0, 0.5) * p.cubeSize);
        PileParams pp;
        const Pile pile = buildPile(set, selectRocks(set, *slab, pp), pp);
        const int size = 4 * span;
        const auto s = slice(*pile.surface, span / 2, size);
        const int margin = 2 * p.voxelsPerCell;
        return std::make_pair(correlation(s, size, span, margin),
                              correlation(s, size, span / 2, margin));
    };
    RockTileParams periodic = smallTiles();
    periodic.tiling = Tiling::Periodic;
    periodic.n = 4;
    RockTileParams aperiodic = smallTiles();
    aperiodic.n = 4;
    const auto per = lagCorrelation(periodic), aper = lagCorrelation(aperiodic);
    EXPECT_GT(per.first, 0.9);          // the pattern repeats at the tile period
    EXPECT_LT(per.second, 0.5);         // and not at half of it
    EXPECT_LT(aper.first, 0.5);         // corner cubes: no repetition at the period
}

TEST(RockPile, DeterministicAcrossThreads)
{
    initialize();
    const TileSet set = generateTiles(smallTiles());
    const auto support = sphere(Vec3d(0.0), 0.9);
    PileParams pp;
    pp.seed = 4;
    Pile a, b;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        a = buildPile(set, selectRocks(set, *support, pp), pp);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        b = buildPile(set, selectRocks(set, *support, pp), pp);
    }
    ASSERT_EQ(a.instances.size(), b.instances.size());
    EXPECT_EQ(a.surface->activeVoxelCount(), b.surface->activeVoxelCount());
    size_t diff = 0;
    auto acc = b.surface->getConstAccessor();
    auto ids = b.rockId->getConstAccessor();
    for (auto it = a.surface->cbeginValueOn(); it; ++it) diff += acc.getValue(it.getCoord()) != *it;
    for (auto it = a.rockId->cbeginValueOn(); it; ++it) diff += ids.getValue(it.getCoord()) != *it;
    EXPECT_EQ(diff, size_t(0));
}

#include <openvdb/points/AttributeArray.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/points/PointDataGrid.h>

TEST(RockPile, InstancePointsCopyTheLibraryOntoThePile)
{
    initialize();
    const TileSet set = generateTiles(smallTiles());
    PileParams pp;
    const Pile pile = buildPile(set, selectRocks(set, *sphere(Vec3d(0.0), 0.9), pp), pp);
    const auto& instances = pile.instances;
    ASSERT_GT(instances.size(), size_t(20));
    auto points = openvdb::gridPtrCast<openvdb::points::PointDataGrid>(instancePoints(instances, set));
    ASSERT_TRUE(points);
    EXPECT_EQ(points->getName(), "rocks");
    EXPECT_EQ(openvdb::points::pointCount(points->tree()), instances.size());
    openvdb::FloatGrid::Ptr ids;
    const auto library = libraryGrid(set, 3.0, nullptr, &ids);
    ASSERT_TRUE(ids);
    EXPECT_EQ(ids->getName(), "rock_id");
    EXPECT_EQ(ids->activeVoxelCount(), library->activeVoxelCount());
    // The library's voxels by rock (rock_id), as Houdini's piece attribute splits them.
    std::vector<std::vector<std::pair<openvdb::Coord, float>>> pieces(set.rocks.size());
    for (auto it = ids->cbeginValueOn(); it; ++it) {
        ASSERT_GE(*it, 0.0f);
        pieces.at(size_t(*it)).emplace_back(it.getCoord(), library->tree().getValue(it.getCoord()));
    }
    // Every (id, rock, tile, position) comes back, each once, with what Houdini's Copy to Points
    // reads: the identity orient, pscale 1, variant = the library rock and pivot = its seed in
    // the library; piece `variant` moved by P − pivot lands on the pile: where the pile holds
    // that rock alone its values are the library's, and the union never lies above them.
    std::vector<int> seen(instances.size(), 0);
    size_t same = 0, checked = 0;
    const auto pileAcc = pile.surface->getConstAccessor();
    const auto idAcc = pile.rockId->getConstAccessor();
    for (auto leaf = points->tree().cbeginLeaf(); leaf; ++leaf) {
        using namespace openvdb::points;
        AttributeHandle<openvdb::Vec3f> P(leaf->constAttributeArray("P"));
        AttributeHandle<int32_t> rock(leaf->constAttributeArray("rock"));
        AttributeHandle<int32_t> tile(leaf->constAttributeArray("tile"));
        AttributeHandle<int32_t> inst(leaf->constAttributeArray("id"));
        AttributeHandle<int32_t> variant(leaf->constAttributeArray("variant"));
        AttributeHandle<float> pscale(leaf->constAttributeArray("pscale"));
        AttributeHandle<openvdb::math::Quats> orient(leaf->constAttributeArray("orient"));
        AttributeHandle<openvdb::Vec3f> pivot(leaf->constAttributeArray("pivot"));
        for (auto idx = leaf->beginIndexOn(); idx; ++idx) {
            const size_t i = size_t(inst.get(*idx));
            ASSERT_LT(i, instances.size());
            ++seen[i];
            EXPECT_EQ(size_t(rock.get(*idx)), instances[i].rock);
            EXPECT_EQ(size_t(tile.get(*idx)), instances[i].region);
            EXPECT_EQ(size_t(variant.get(*idx)), instances[i].rock);
            EXPECT_EQ(pscale.get(*idx), 1.0f);
            EXPECT_EQ(orient.get(*idx), openvdb::math::Quats(0, 0, 0, 1));
            const Vec3d w = points->transform().indexToWorld(P.get(*idx) + idx.getCoord().asVec3d());
            EXPECT_LT((w - instances[i].position).length(), 1e-4);
            // P − pivot in voxels: a whole number of them.
            const Vec3d shift = (w - Vec3d(pivot.get(*idx))) / library->voxelSize()[0];
            const openvdb::Coord d(openvdb::Coord::round(shift));
            ASSERT_LT((shift - d.asVec3d()).length(), 1e-3) << i;
            for (const auto& [c, value] : pieces[size_t(variant.get(*idx))]) {
                const openvdb::Coord q = c + d;
                EXPECT_LE(pileAcc.getValue(q), value + 1e-6f);
                if (idAcc.getValue(q) == float(i) && std::abs(value) < 0.5f * library->background()) {
                    ++checked;
                    same += pileAcc.getValue(q) == value;
                }
            }
        }
    }
    EXPECT_EQ(size_t(std::count(seen.begin(), seen.end(), 1)), instances.size());
    ASSERT_GT(checked, size_t(1000));
    EXPECT_GT(double(same) / double(checked), 0.9) << same << " of " << checked;
}
