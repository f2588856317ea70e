// SPDX-License-Identifier: Apache-2.0
// rockvdb_bench — each issue's numbers beside a reference run in the same process.
// usage: rockvdb_bench [--quick] [foundation] [blocks] [amplify] [detail] [rockpile] [fill]
//        [fractal] [arches] [samples] [asset]   (no group: all of them)
#include <rockvdb/amplify/Amplify.h>
#include <rockvdb/arches/Edits.h>
#include <rockvdb/arches/StackBake.h>
#include <rockvdb/arches/StackBuild.h>
#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/Weights.h>
#include <rockvdb/asset/AssetStage.h>
#include <rockvdb/arches/Stabilize.h>
#include <rockvdb/blocks/BlockTile.h>
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/detail/Detail.h>
#include <rockvdb/fractal/FractalStage.h>
#include <rockvdb/fractal/MeshBake.h>
#include <rockvdb/rockpile/RockPile.h>
#include <rockvdb/rockpile/RockPileStage.h>
#include <rockvdb/rockpile/RockTiles.h>
#include <openvdb/tools/Composite.h>

#include <nlohmann/json.hpp>

#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <sys/resource.h>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>

using namespace rockvdb;

namespace {

double bestOf(int reps, const std::function<void()>& fn)
{
    double best = 1e30;
    for (int i = 0; i < reps; ++i) {
        const auto t0 = std::chrono::steady_clock::now();
        fn();
        best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return best;
}

void foundation(bool quick)
{
    std::printf("## foundation: sparse baker vs tools::createLevelSetSphere (same run)\n\n");
    std::printf("| sphere | threads | active voxels | rockvdb bake | createLevelSetSphere | ratio | voxels/s (rockvdb) |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    const double dx = 0.01;
    for (int radiusVoxels : {100, 200}) {
        const double R = radiusVoxels * dx;
        auto field = sphere(Vec3d(0), R);
        BakeSettings s;
        s.voxelSize = dx;
        for (int threads : {1, 2}) {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
            size_t active = 0;
            const int reps = quick ? 2 : 5;
            const double ours = bestOf(reps, [&] { active = bake(*field, s).surface->activeVoxelCount(); });
            const double ref = bestOf(reps, [&] {
                openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(float(R), Vec3f(0), float(dx), 3.0f);
            });
            std::printf("| R=%d voxels | %d | %zu | %.1f ms | %.1f ms | %.1fx | %.3g |\n", radiusVoxels,
                        threads, active, ours * 1e3, ref * 1e3, ref / ours, double(active) / ours);
            std::printf("ratio sphere R=%d threads=%d vs createLevelSetSphere: %.1fx\n", radiusVoxels,
                        threads, ref / ours);
        }
    }
    std::printf("\n## foundation: sparse baker vs the mesh route (volumeToMesh + meshToLevelSet)\n\n");
    std::printf("| sphere | threads | rockvdb bake | mesh route | ratio |\n|---|---|---|---|---|\n");
    for (int radiusVoxels : {100, 200}) {
        const double R = radiusVoxels * dx;
        auto field = sphere(Vec3d(0), R);
        BakeSettings s;
        s.voxelSize = dx;
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        openvdb::FloatGrid::Ptr grid;
        const double ours = bestOf(3, [&] { grid = bake(*field, s).surface; });
        const double mesh = bestOf(1, [&] {
            std::vector<openvdb::Vec3s> pts;
            std::vector<openvdb::Vec3I> tris;
            std::vector<openvdb::Vec4I> quads;
            openvdb::tools::volumeToMesh(*grid, pts, tris, quads, 0.0, 0.0);
            openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(grid->transform(), pts, tris, quads, 3.0f);
        });
        std::printf("| R=%d voxels | 2 | %.1f ms | %.1f ms | %.1fx |\n", radiusVoxels, ours * 1e3,
                    mesh * 1e3, mesh / ours);
        std::printf("ratio sphere R=%d threads=2 vs mesh route: %.1fx\n", radiusVoxels, mesh / ours);
    }
}

void blocksGroup(bool quick)
{
    using namespace rockvdb::blocks;
    std::printf("\n## blocks: tile generation (sampling through hulls) beside the paper's Table 1\n\n");
    std::printf("| type | #P | #D | #B | mean #Pi | generation | paper #P / #D / #B / #Pi | paper time | speed-up |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    struct Paper { BlockType type; int P, D, B, Pi; double seconds; };
    const Paper paper[] = {{BlockType::Equidimensional, 14524, 15, 125, 110, 6.9},
                           {BlockType::Rhombohedral, 14589, 24, 78, 161, 12.0},
                           {BlockType::Polyhedral, 14532, 44, 100, 140, 25.4},
                           {BlockType::Tabular, 14554, 30, 82, 143, 16.3}};
    std::vector<std::shared_ptr<const BlockTile>> tiles;
    for (const Paper& ref : paper) {
        BlockTileParams p;
        p.type = ref.type;
        p.seed = 7;
        std::shared_ptr<const BlockTile> tile;
        const double t = bestOf(quick ? 1 : 3, [&] { tile = std::make_shared<const BlockTile>(generateTile(p)); });
        const BlockTileStats& st = tile->stats;
        std::printf("| %s | %zu | %zu | %zu | %.0f | %.3f s | %d / %d / %d / %d | %.1f s | %.0fx |\n",
                    blockTypeName(ref.type), st.points, st.discs, st.blocks, st.meanPoints, t,
                    ref.P, ref.D, ref.B, ref.Pi, ref.seconds, ref.seconds / t);
        std::printf("ratio blocks %s generation vs paper: %.1fx\n", blockTypeName(ref.type), ref.seconds / t);
        tiles.push_back(tile);
    }
    std::printf("\n## blocks: tile bake at 5 cm (2 threads), and the cell-culled tile field vs a generic union (same run)\n\n");
    std::printf("| type | active voxels | tile bake | 3 m region: tile field | generic union | ratio |\n|---|---|---|---|---|---|\n");
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    for (size_t k = 0; k < tiles.size(); ++k) {
        const auto& tile = tiles[k];
        BakeSettings s;
        s.voxelSize = 0.05;
        s.withAttribute = true;
        size_t active = 0;
        const double full = quick ? 0.0 : bestOf(1, [&] {
            active = bake(*tileField(tile, TileFieldOptions{}), s).surface->activeVoxelCount();
        });
        // Same region with both evaluators.
        BakeSettings r = s;
        r.withAttribute = false;
        r.region = BBoxd(Vec3d(8), Vec3d(11));
        std::vector<FieldPtr> parts;
        for (size_t j = 0; j < tile->blocks.size(); ++j) parts.push_back(blockField(tile, j));
        auto generic = csg(CsgOp::Union, parts);
        auto field = tileField(tile, TileFieldOptions{});
        const double ours = bestOf(2, [&] { bake(*field, r); });
        const double ref = bestOf(1, [&] { bake(*generic, r); });
        std::printf("| %s | %zu | %.2f s | %.3f s | %.3f s | %.1fx |\n", blockTypeName(tile->params.type),
                    active, full, ours, ref, ref / ours);
        std::printf("ratio blocks %s tile field vs generic union: %.1fx\n",
                    blockTypeName(tile->params.type), ref / ours);
    }
}

// A sea cliff: a plateau ~30 m high on one side of a wavy coastline, the sea floor at 0 on
// the other, joined by a 70° cliff; size × size metres at 0.5 m cells.
std::shared_ptr<Heightfield> seaCliff(double size)
{
    auto hf = std::make_shared<Heightfield>();
    hf->cellSize = 0.5;
    hf->nx = hf->ny = int(size / hf->cellSize) + 1;
    noise::Fbm f;
    f.frequency = 0.02;
    f.octaves = 3;
    for (int j = 0; j < hf->ny; ++j)
        for (int i = 0; i < hf->nx; ++i) {
            const double x = i * hf->cellSize, y = j * hf->cellSize;
            const double coast = 0.5 * size + 12.0 * noise::fbm2(7, f, float(x), float(y));
            const double t = std::clamp((coast - x) / 11.0 + 0.5, 0.0, 1.0); // 30 m over 11 m
            hf->z.push_back(float(30.0 * t + 1.5 * noise::fbm2(9, f, float(x * 4), float(y * 4))));
        }
    return hf;
}

void amplifyGroup(bool quick)
{
    using namespace rockvdb::blocks;
    using Clock = std::chrono::steady_clock;
    auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
    std::printf("\n## amplify: sea cliff at 10 cm voxels (2 threads), beside the paper's Table 2\n\n");
    std::printf("| scene | #R | block fields (tileFieldBytes) | active voxels | presence | bake + split | total | peak RSS | paper's scene of that size |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    // A 10 m equidimensional tile (blocks of ~2 m, as the paper's cliffs show); anchors from
    // 1.5 m inside the rock to 2 m outside (the distance range's default upper end).
    BlockTileParams p;
    p.seed = 7;
    p.tileSize = 10;
    auto tile = std::make_shared<const BlockTile>(generateTile(p));
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    double first = 0;
    struct Reference { double size, total, blocks, terrain, single; };
    std::vector<Reference> refs;
    for (double size : quick ? std::vector<double>{100} : std::vector<double>{100, 200}) {
        const auto t0 = Clock::now();
        amplify::PlacementRules rules;
        rules.distanceMin = -1.5;
        auto ground = amplify::heightfieldTerrain(seaCliff(size), 2.0, rules);
        amplify::AmplifyStats st;
        const auto parts = amplify::amplifiedParts(ground, {tile}, rules, st);
        BakeSettings s;
        s.voxelSize = 0.1;
        const auto r = amplify::bakeAmplified(parts, s, st);
        const size_t active = r.surface->activeVoxelCount();
        const double bakeS = st.bakeSeconds + st.splitSeconds;
        const double total = since(t0);
        struct rusage ru;
        getrusage(RUSAGE_SELF, &ru);
        std::printf("| %.0f x %.0f m | %zu | %.2f MB | %zu | %.2f s | %.1f s | %.1f s | %.2f GB | %s |\n",
                    size, size, st.replicated, st.blockBytes / 1e6, active, st.presenceSeconds, bakeS,
                    total, double(ru.ru_maxrss) / 1e6,
                    size == 100 ? "sea cliff 100 x 100 m: #R 959, 0.57 MB"
                                : "none (its largest: sea spire 150 x 150 m, #R 1680, 0.53 MB)");
        // References in this process: the same blocks' tile field alone over its band (the
        // stage's floor: the blocks have to be evaluated), the bare terrain, and the single
        // bake of the united field that amplify made before the parts were baked apart.
        Reference ref{size, total, 0, 0, 0};
        s.withAttribute = true;
        ref.blocks = bestOf(1, [&] { bake(*parts.blocks, s); });
        s.withAttribute = false;
        ref.terrain = bestOf(1, [&] { bake(*parts.terrain, s); });
        if (size == 100) {
            s.withAttribute = true;
            ref.single = bestOf(1, [&] { bake(*parts.united(), s); });
        }
        refs.push_back(ref);
        if (size == 100) first = total;
        else std::printf("ratio amplify 200 m vs 100 m: %.2fx (area 4x)\n", total / first);
    }
    std::printf("\n| scene | amplify (presence + both bakes + union + split) | tile field alone (reference) | ratio | bare terrain | one-field union (before) | speed-up |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    for (const Reference& r : refs) {
        char single[64] = "", speedup[64] = "";
        if (r.single > 0) {
            std::snprintf(single, sizeof single, "%.1f s", r.single);
            std::snprintf(speedup, sizeof speedup, "%.1fx", r.single / r.total);
        }
        std::printf("| %.0f x %.0f m | %.2f s | %.2f s | %.2fx | %.2f s | %s | %s |\n", r.size, r.size,
                    r.total, r.blocks, r.total / r.blocks, r.terrain, single, speedup);
        std::printf("ratio amplify %.0f m vs its tile field alone: %.2fx (target <= 2)\n", r.size,
                    r.total / r.blocks);
    }
}

} // namespace

void detailGroup(bool quick)
{
    std::printf("\n## detail: a level-set sphere of ~1.5 M active voxels (2 threads)\n\n");
    std::printf("| operator | time | active voxels | voxels/s | vs plain re-bake (same grid) |\n");
    std::printf("|---|---|---|---|---|\n");
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    const float dx = quick ? 0.02f : 0.01f;
    auto sphere = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(1.41f, openvdb::Vec3f(0), dx);
    BakeSettings s;
    s.voxelSize = dx;
    auto run = [&](const detail::DetailParams& p) {
        const auto t0 = std::chrono::steady_clock::now();
        const BakeResult r = detail::detailLevelSet(sphere, p, s);
        return std::make_pair(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                              size_t(r.surface->activeVoxelCount()));
    };
    detail::DetailParams none = detail::DetailParams::fromJson(nlohmann::json::object());
    const auto ref = run(none);
    std::printf("| plain re-bake (reference) | %.2f s | %zu | %.2f M | 1.0x |\n", ref.first, ref.second,
                double(ref.second) / ref.first / 1e6);
    struct Case { const char* name; nlohmann::json j; };
    const Case cases[] = {
        {"gradient warp, A = 3 cm, p = 8", {{"warp-amplitude", 0.03}, {"warp-scale", 0.6}}},
        {"Gabor, A = 3 cm, F0 = 6/m, axis frames", {{"gabor-amplitude", 0.03}, {"gabor-frequency", 6.0}, {"direction-axis", {0, 0, 1}}}},
        {"Gabor, curvature frames", {{"gabor-amplitude", 0.03}, {"gabor-frequency", 6.0}, {"direction-curvature", true}}},
        {"warp + Gabor", {{"warp-amplitude", 0.03}, {"warp-scale", 0.6}, {"gabor-amplitude", 0.03}, {"gabor-frequency", 6.0}, {"direction-axis", {0, 0, 1}}}},
    };
    for (const Case& k : cases) {
        const auto m = run(detail::DetailParams::fromJson(k.j));
        std::printf("| %s | %.2f s | %zu | %.2f M | %.1fx |\n", k.name, m.first, m.second,
                    double(m.second) / m.first / 1e6, m.first / ref.first);
    }
    if (quick) return;
    // The demo's detail step at scale: an amplified 100 m sea cliff at 10 cm (the amplify
    // group's, with its block ids), detailed as the demo does (warp 0.12 m + horizontal Gabor
    // ridges 0.08 m) and its ids carried, beside the plain re-bake of the same grid.
    std::printf("\n| detail of the amplified 100 m sea cliff (10 cm) | time | active voxels | vs plain re-bake |\n");
    std::printf("|---|---|---|---|\n");
    amplify::PlacementRules rules;
    rules.distanceMin = -1.5;
    blocks::BlockTileParams tp;
    tp.seed = 7;
    tp.tileSize = 10;
    auto tile = std::make_shared<const blocks::BlockTile>(blocks::generateTile(tp));
    amplify::AmplifyStats st;
    const auto parts = amplify::amplifiedParts(amplify::heightfieldTerrain(seaCliff(100), 2.0, rules),
                                               {tile}, rules, st);
    BakeSettings cs;
    cs.voxelSize = 0.1;
    const auto cliff = amplify::bakeAmplified(parts, cs, st);
    auto timed = [&](const detail::DetailParams& p, bool ids) {
        const auto t0 = std::chrono::steady_clock::now();
        openvdb::FloatGrid::ConstPtr wide;
        const BakeResult r = detail::detailLevelSet(cliff.surface, p, cs, nullptr, &wide);
        if (ids) detail::carryAttributes(*wide, *r.surface, {cliff.blockId.get(), cliff.material.get()});
        return std::make_pair(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
                              size_t(r.surface->activeVoxelCount()));
    };
    const auto plain = timed(none, false);
    std::printf("| plain re-bake (reference) | %.2f s | %zu | 1.0x |\n", plain.first, plain.second);
    const auto demo = timed(detail::DetailParams::fromJson(
        {{"warp-amplitude", 0.12}, {"warp-scale", 3.0}, {"gabor-amplitude", 0.08},
         {"gabor-frequency", 1.2}, {"direction-axis", {0, 0, 1}}}), true);
    std::printf("| warp 0.12 m + Gabor 0.08 m, axis frames, block ids carried | %.2f s | %zu | %.1fx |\n",
                demo.first, demo.second, demo.first / plain.first);
    std::printf("ratio detail of the cliff vs its plain re-bake: %.1fx\n", demo.first / plain.first);
}

void rockpileGroup(bool quick)
{
    using Clock = std::chrono::steady_clock;
    auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    std::printf("\n## rockpile: tile sets (2 threads) beside the rock-piles paper's Table 1 (one core), reference: tools::volumeToMesh of the same rocks (the paper's last phase) in this process\n\n");
    std::printf("| n | stones (paper) | voronoi + erosion | level sets | tiles total | paper | volumeToMesh of the library | level sets vs meshing |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    const int paperStones[] = {7355, 17166, 33217};
    const double paperSeconds[] = {23, 73, 176};
    rockpile::TileSet five;
    for (int n : quick ? std::vector<int>{5} : std::vector<int>{5, 7}) {
        rockpile::RockTileParams p;
        p.n = n;
        const auto t0 = Clock::now();
        rockpile::TileSet set = rockpile::generateTiles(p);
        const double tiles = since(t0);
        const auto t1 = Clock::now();
        auto lib = rockpile::libraryGrid(set);
        const double ls = since(t1);
        const auto t2 = Clock::now();
        std::vector<openvdb::Vec3s> pts;
        std::vector<openvdb::Vec3I> tris;
        std::vector<openvdb::Vec4I> quads;
        openvdb::tools::volumeToMesh(*lib, pts, tris, quads, 0.0);
        const double mesh = since(t2);
        std::printf("| %d | %zu (%d) | %.2f s | %.2f s | %.2f s | %.0f s | %.2f s | %.2fx |\n", n,
                    set.stats.stones, paperStones[n - 5], set.stats.voronoiSeconds, ls, tiles + ls,
                    paperSeconds[n - 5], mesh, ls / mesh);
        if (n == 5) five = std::move(set);
    }

    std::printf("\n## rockpile: instancing into a support (2 threads), reference: the same rocks united one by one with tools::csgUnion\n\n");
    std::printf("| support | rocks placed | select | level set + ids | rocks/s | csgUnion reference (first 1000 rocks) | ratio |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    const double side = quick ? 6.0 : 14.0;
    auto slab = box(Vec3d(0.0), Vec3d(side / 2, side / 2, 0.5));
    rockpile::PileParams pp;
    rockpile::PileStats st;
    auto instances = rockpile::selectRocks(five, *slab, pp, &st);
    const auto t3 = Clock::now();
    rockpile::Pile pile = rockpile::buildPile(five, instances, pp);
    const double build = since(t3);
    // Reference: the first 1000 rocks' level sets united into one grid with csgUnion, beside
    // buildPile on the same 1000.
    std::vector<rockpile::Instance> first(instances.begin(), instances.begin() + std::min<size_t>(1000, instances.size()));
    const double dx = five.params.voxelSize();
    const auto t4 = Clock::now();
    auto acc = openvdb::FloatGrid::create(float(3 * dx));
    acc->setTransform(openvdb::math::Transform::createLinearTransform(dx));
    acc->setGridClass(openvdb::GRID_LEVEL_SET);
    for (const auto& in : first) {
        auto g = rockpile::rockLevelSet(five.rocks[in.rock], dx, in.shift);
        openvdb::tools::csgUnion(*acc, *g);
    }
    const double ref = since(t4);
    const auto t5 = Clock::now();
    rockpile::buildPile(five, first, pp);
    const double ours = since(t5);
    std::printf("| slab %.0f x %.0f x 1 m, n = 5 tiles | %zu | %.2f s | %.2f s | %.0f | %.2f s vs %.3f s | %.1fx |\n",
                side, side, instances.size(), st.selectSeconds, build,
                double(instances.size()) / (st.selectSeconds + build), ref, ours, ref / ours);
}

// Issue 14: blocks grown to their fractures (the default) beside the hull-only reading, same run:
// the share of the 20 m tile inside a block (the periodic tile field at uniform samples, warp
// and rounding included) and the generation time. Targets: fill >= 0.85, generation <= 0.5 s.
void fillGroup(bool quick)
{
    using namespace rockvdb::blocks;
    std::printf("\n## blocks: filling the tile (the default) vs the hull-only reading (--no-fill; 20 m tiles, seed 7)\n\n");
    std::printf("| type | blocks | hull only | generation | filled (default) | generation |\n");
    std::printf("|---|---|---|---|---|---|\n");
    const int samples = quick ? 2000 : 20000;
    for (int t = 0; t < 6; ++t) {
        double share[2], seconds[2];
        size_t blocks = 0;
        for (int fill = 0; fill < 2; ++fill) {
            BlockTileParams p;
            p.type = BlockType(t);
            p.seed = 7;
            p.fill = fill == 1;
            std::shared_ptr<const BlockTile> tile;
            seconds[fill] = bestOf(quick ? 1 : 3, [&] {
                tile = std::make_shared<const BlockTile>(generateTile(p));
            });
            blocks = tile->blocks.size();
            TileFieldOptions o;
            o.periodic = true;
            const FieldPtr f = tileField(tile, o);
            int inside = 0;
            for (int k = 0; k < samples; ++k) {
                const Vec3d q(random::uniform(11, 1, uint64_t(k), 0, 20), random::uniform(11, 2, uint64_t(k), 0, 20),
                              random::uniform(11, 3, uint64_t(k), 0, 20));
                inside += f->eval(q) < 0;
            }
            share[fill] = double(inside) / samples;
        }
        std::printf("| %s | %zu | %.2f | %.3f s | %.2f | %.3f s |\n", blockTypeName(BlockType(t)),
                    blocks, share[0], seconds[0], share[1], seconds[1]);
        std::printf("ratio fill %s vs hull-only: %.2fx\n", blockTypeName(BlockType(t)),
                    share[1] / share[0]);
    }
    // Issue 38 §2: the share of rock at other tile sizes, beside the 20 m tile (R and the warp
    // scale with the tile by default, so every size should match it).
    std::printf("\n## blocks: share of rock by tile size (default rows, seed 3), reference: the 20 m tile\n\n");
    std::printf("| type | 5 m | 10 m | 20 m (reference) | 40 m | worst ratio to 20 m |\n|---|---|---|---|---|---|\n");
    for (int t = 0; t < 6; ++t) {
        double share[4];
        const double sizes[4] = {5, 10, 20, 40};
        for (int k = 0; k < 4; ++k) {
            BlockTileParams p;
            p.type = BlockType(t);
            p.tileSize = sizes[k];
            p.seed = 3;
            TileFieldOptions o;
            o.periodic = true;
            const FieldPtr f = tileField(std::make_shared<const BlockTile>(generateTile(p)), o);
            int inside = 0;
            for (int j = 0; j < samples; ++j) {
                const Vec3d q(random::uniform(11, 1, uint64_t(j), 0, sizes[k]),
                              random::uniform(11, 2, uint64_t(j), 0, sizes[k]),
                              random::uniform(11, 3, uint64_t(j), 0, sizes[k]));
                inside += f->eval(q) < 0;
            }
            share[k] = double(inside) / samples;
        }
        const double worst = std::min({share[0], share[1], share[3]}) / share[2];
        std::printf("| %s | %.3f | %.3f | %.3f | %.3f | %.3f |\n", blockTypeName(BlockType(t)), share[0],
                    share[1], share[2], share[3], worst);
    }
}

// Fractal rocks (issue 16): the paper's performance table (2004 hardware, one rock) beside the
// mesh generation here; the direct bake beside tools::meshToVolume of the same meshes in this
// process (the ratio is the claim); the scatter's rocks per second, both ways.
void fractalGroup(bool quick)
{
    using namespace rockvdb::fractal;
    const int reps = quick ? 2 : 5;
    std::printf("\n## fractal: rock meshes (2 threads) beside the paper's table (2004 hardware)\n\n");
    std::printf("| method | levels | triangles | here | paper | paper / here |\n|---|---|---|---|---|---|\n");
    struct Row { Method m; int L; double paperMs; };
    // The paper's rows by triangle count: 320 and 5 120 triangles (its midpoint rows reach
    // them in 2 and 4 of our 4-way levels).
    const Row rows[] = {{Method::Interpolating, 1, 146.25}, {Method::Interpolating, 2, 632.25},
                        {Method::Interpolating, 3, 0}, {Method::Midpoint, 2, 391.25},
                        {Method::Midpoint, 4, 4477.75}, {Method::Midpoint, 6, 0}};
    for (const Row& r : rows) {
        RockShape s;
        s.levels = r.L;
        s.method = r.m;
        s.roughness = 0.12;
        s.hUp = 0.65;
        s.hDown = 0.9;
        s.seed = 5;
        const std::array<Vec3d, 3> R = randomOrientation(5, 20);
        size_t tris = 0;
        const double t = bestOf(reps, [&] {
            Task task;
            const RockMesh m = buildRock(s, Vec3d(0.5, 0.4, 0.25), R, task);
            tris = m.triangles.size();
        });
        if (r.paperMs > 0) {
            std::printf("| %s | %d | %zu | %.2f ms | %.0f ms | %.0fx |\n", methodName(r.m), r.L, tris,
                        t * 1e3, r.paperMs, r.paperMs / (t * 1e3));
        } else {
            std::printf("| %s | %d | %zu | %.2f ms | - | - |\n", methodName(r.m), r.L, tris, t * 1e3);
        }
    }
    auto meshToVolumeOf = [](const std::vector<MeshPart>& parts, double dx) {
        auto xf = openvdb::math::Transform::createLinearTransform(dx);
        std::vector<openvdb::Vec3s> idx;
        std::vector<openvdb::Vec3I> tris;
        for (const auto& p : parts) {
            const unsigned off = unsigned(idx.size());
            for (const auto& q : *p.points) idx.emplace_back(xf->worldToIndex(q));
            for (const auto& t : *p.triangles) tris.push_back(t + openvdb::Vec3I(off));
        }
        openvdb::tools::QuadAndTriangleDataAdapter<openvdb::Vec3s, openvdb::Vec3I> ad(idx, tris);
        return openvdb::tools::meshToVolume<openvdb::FloatGrid>(ad, *xf, 3.0f, 3.0f);
    };
    std::printf("\n## fractal: level sets (2 threads), reference: tools::meshToVolume of the same mesh\n\n");
    std::printf("| rock | triangles | voxel | active voxels | direct bake | meshToVolume | ratio |\n|---|---|---|---|---|---|---|\n");
    for (int L : {2, 3}) {
        FractalRockParams p;
        p.shape.levels = L;
        p.size = Vec3d(1.0, 0.8, 0.5);
        p.shape.seed = 5;
        Task task;
        const RockResult r = runRock(p, false, false, task);
        std::vector<Vec3d> world;
        for (const auto& q : r.mesh.points) world.emplace_back(q);
        const std::vector<MeshPart> parts{{&world, &r.mesh.triangles}};
        openvdb::FloatGrid::Ptr g;
        const double ours = bestOf(reps, [&] { Task t2; g = bakeMeshes(parts, 0.01, 3.0, true, t2); });
        const double ref = bestOf(reps, [&] { meshToVolumeOf(parts, 0.01); });
        std::printf("| 1 x 0.8 x 0.5 m, level %d | %zu | 1 cm | %zu | %.1f ms | %.1f ms | %.1fx |\n", L,
                    r.mesh.triangles.size(), size_t(g->activeVoxelCount()), ours * 1e3, ref * 1e3, ref / ours);
    }
    std::printf("\n## fractal: scatter of 1000 rocks (~0.5 m) at 2 cm (2 threads), reference: one meshToVolume of all the meshes\n\n");
    std::printf("| levels | placed | place + meshes | direct bake | rocks/s | meshToVolume | rocks/s | ratio |\n|---|---|---|---|---|---|---|---|\n");
    for (int L : {1, 2}) {
        FractalRockParams p;
        p.count = quick ? 300 : 1000;
        p.shape.levels = L;
        p.size = Vec3d(0.6, 0.5, 0.35);
        p.voxelSize = 0.02;
        p.area = std::array<double, 4>{-12, -12, 12, 12};
        const auto ground = planeGround();
        ScatterResult r;
        const double total = bestOf(quick ? 1 : 2, [&] {
            Task task;
            r = runScatter(p, *ground, false, true, task);
        });
        (void)total;
        // The same rocks' meshes (the scatter's grouped mesh), for the reference.
        std::vector<Vec3d> allPoints;
        for (const auto& q : r.mesh.points) allPoints.emplace_back(q);
        const std::vector<MeshPart> all{{&allPoints, &r.mesh.triangles}};
        const double ref = bestOf(1, [&] { meshToVolumeOf(all, 0.02); });
        const double ours = r.stats.levelSetSeconds;
        const double n = double(r.stats.placed);
        std::printf("| %d | %zu | %.3f s | %.2f s | %.0f | %.2f s | %.0f | %.1fx |\n", L, r.stats.placed,
                    r.stats.placeSeconds + r.stats.meshSeconds, ours,
                    n / (r.stats.placeSeconds + r.stats.meshSeconds + ours), ref,
                    n / (r.stats.placeSeconds + r.stats.meshSeconds + ref), ref / ours);
    }
}

// Issue 17: the bench's material-stack terrain: procedural strata (bedrock, sand, bedrock, an
// air band of overhangs, bedrock, rocks, bedrock) under an fBm top, 1 m stacks.
rockvdb::arches::StrataSpec strataScene(int nx, int ny, double quantum)
{
    using namespace rockvdb::arches;
    StrataSpec spec;
    spec.geometry.nx = nx;
    spec.geometry.ny = ny;
    spec.geometry.quantum = quantum;
    spec.base = 45.0;
    spec.amplitude = 30.0;
    spec.frequency = 0.01;
    spec.warp = 2.0;
    spec.warpFrequency = 0.03;
    spec.seed = 3;
    spec.strata = {{Material::Bedrock, 20}, {Material::Sand, 3}, {Material::Bedrock, 8},
                   {Material::Air, 4}, {Material::Bedrock, 6}, {Material::Rocks, 2}, {Material::Bedrock, 100}};
    return spec;
}

// Issue 17: material stacks at the sizes of the arches paper's Table 1.
void archesGroup(bool quick)
{
    using namespace rockvdb::arches;
    struct Scene
    {
        const char* name;
        int nx, ny, levels;
        double paperMB;
    };
    const Scene scenes[] = {{"cave", 1000, 750, 8000, 21}, {"canyon", 1000, 500, 5000, 14}, {"cliff", 2000, 500, 4000, 26}};
    std::printf("\n## arches: material stacks at the paper's Table 1 sizes (procedural strata with an overhang band)\n\n");
    std::printf("| scene | effective resolution | layers / stack | stack memory | paper | dense voxels (1 B) | ground level set | build |\n|---|---|---|---|---|---|---|---|\n");
    for (const Scene& sc : scenes) {
        if (quick && sc.nx > 1000) continue;
        // Effective resolution: the top's 80 m range in sc.levels quanta.
        const StrataSpec spec = strataScene(sc.nx, sc.ny, 80.0 / sc.levels);
        Stacks st;
        Task task;
        const double build = bestOf(1, [&] { st = stacksFromStrata(spec, task); });
        std::string vdb = "-";
        if (!quick || (sc.nx == 1000 && sc.ny == 750)) {
            // The same ground as an OpenVDB level set (bytes in memory), at the cell size.
            SkeletonBake b;
            b.sigma = 0.5;
            b.voxelSize = 1.0;
            auto g = bakeSkeleton(Skeleton(st, kGroundMask), b, task);
            char buf[64];
            std::snprintf(buf, sizeof buf, "%.0f MB", double(g->memUsage()) / 1e6);
            vdb = buf;
        }
        std::printf("| %s | %d x %d x %d | %.2f | %.1f MB (%.1f B/stack) | %.0f MB | %.1f GB | %s | %.2f s |\n", sc.name, sc.nx,
                    sc.ny, sc.levels, double(st.layerCount()) / double(st.geometry().count()), double(st.bytes()) / 1e6,
                    double(st.bytes()) / double(st.geometry().count()), sc.paperMB,
                    double(sc.nx) * sc.ny * sc.levels / 1e9, vdb.c_str(), build);
    }
    // Stabilise after dropping 0.5 m of sand on every stack of the 1000 x 750 scene; bake its
    // ground at the cell size; the convolution's evaluations per second beside the sphere's.
    const StrataSpec spec = strataScene(1000, 750, 0.01);
    Task task;
    const Stacks strata = stacksFromStrata(spec, task);
    const Stacks dropped = Stacks::build(strata.geometry(), [&](int i, int j, std::vector<Layer>& out) {
        strata.layers(i, j, out);
        out.push_back(Layer{Material::Sand, 50});
    }, task);
    StabilizeStats st;
    Stacks stable;
    const double stab = bestOf(1, [&] { stable = stabilizeStacks(dropped, ReposeAngles(), task, &st); });
    std::printf("\n| 1000 x 750 scene | time | target | worklist visits | moves | moved |\n|---|---|---|---|---|---|\n");
    std::printf("| stabilise after 0.5 m of sand everywhere | %.2f s | <= 5 s | %zu | %zu | %.0f m3 |\n", stab, st.visits, st.moves,
                double(st.movedQuanta) * 0.01);
    SkeletonBake b;
    b.sigma = 0.5;
    b.voxelSize = 1.0;
    openvdb::FloatGrid::Ptr ground;
    BakeStats bs;
    const double bk = bestOf(1, [&] { ground = bakeSkeleton(Skeleton(stable, kGroundMask), b, task, &bs); });
    std::printf("| bake the ground at 1 m (sigma 0.5 m), kernel box (§3.3) | %.2f s | <= 20 s | %zu active voxels | %zu evaluations | |\n", bk,
                size_t(ground->activeVoxelCount()), bs.fieldEvaluations);
    // Issue 38: the default kernel (interpolate, reach 4 cells) beside the box, same run.
    {
        SkeletonBake bi = b;
        bi.kernel = Kernel::Interpolate;
        bi.reach = 4.0 * stable.geometry().cell;
        BakeStats is;
        openvdb::FloatGrid::Ptr g;
        const double ik = bestOf(1, [&] { g = bakeSkeleton(Skeleton(stable, kGroundMask), bi, task, &is); });
        std::printf("| the same, kernel interpolate (the default) | %.2f s | ratio %.2f to box | %zu active voxels | %zu evaluations | |\n",
                    ik, ik / bk, size_t(g->activeVoxelCount()), is.fieldEvaluations);
    }
    // Issue 18: the weight_<material> grids (§6) on that ground's band.
    const double wt = bestOf(1, [&] {
        visibleWeights(stable, {Material::Sand, Material::Bedrock, Material::Rocks}, 0.5, *ground, task);
    });
    std::printf("| weight_sand / _bedrock / _rocks on its band (§6) | %.2f s | | %.0f ns per voxel | | |\n", wt,
                wt * 1e9 / double(ground->activeVoxelCount()) * 2.0);
    // Evaluations per second: the convolution vs the baker's analytic sphere, same run.
    auto conv = convolutionField(std::make_shared<Skeleton>(stable, kGroundMask), 0.5);
    auto ball = sphere(Vec3d(500, 375, 40), 30.0);
    BatchBuffer batch;
    batch.n = kMaxBatch;
    std::vector<float> out(kMaxBatch);
    auto rate = [&](const Field& f) {
        size_t n = 0;
        const double t = bestOf(3, [&] {
            n = 0;
            for (int r = 0; r < 400; ++r) {
                for (int k = 0; k < kMaxBatch; ++k) {
                    batch.x[k] = float(100 + (r * 7 + k) % 800);
                    batch.y[k] = float(100 + (r * 13 + k / 8) % 550);
                    batch.z[k] = float(20 + (k % 64));
                }
                f.evalBatch(batch.view(), out.data());
                n += kMaxBatch;
            }
        });
        return double(n) / t;
    };
    const double rc = rate(*conv), rs = rate(*ball);
    std::printf("| field evaluations, 1 thread | %.1f M/s convolution | %.1f M/s analytic sphere | ratio %.2f | | |\n", rc / 1e6,
                rs / 1e6, rc / rs);
    auto interp = interpolatedField(std::make_shared<Skeleton>(stable, kGroundMask), 0.5, 4.0);
    const double ri = rate(*interp);
    std::printf("| field evaluations, 1 thread | %.1f M/s interpolate | %.1f M/s convolution | ratio %.2f | | |\n", ri / 1e6,
                rc / 1e6, ri / rc);
    // Issue 18, §5 (paper Table 2): a tile set generated once, its rocks instanced in the rock
    // layers of a 100 x 75 m strata scene (a 1.5 m rock stratum under the top).
    if (!quick) {
        rockpile::RockTileParams tp;
        tp.n = 4;
        tp.cubeSize = 4.0;
        tp.voxelsPerCell = 6;
        tp.seed = 5;
        rockpile::TilesResult tr;
        const double gen = bestOf(1, [&] { tr = rockpile::runTiles(tp, false, task); });
        const std::string tilesPath = "/tmp/rockvdb_bench_tiles.vdb";
        writeGrids(tilesPath, {tr.rho});
        StrataSpec rs;
        rs.geometry.nx = 200;
        rs.geometry.ny = 150;
        rs.geometry.cell = 0.5;
        rs.geometry.quantum = 0.01;
        rs.base = 12.0;
        rs.amplitude = 4.0;
        rs.frequency = 0.03;
        rs.warp = 0.5;
        rs.strata = {{Material::Bedrock, 10.5}, {Material::Rocks, 1.5}, {Material::Bedrock, 30.0}};
        const Stacks rocky = stacksFromStrata(rs, task);
        ArchesParams ap;
        ap.terrain = nlohmann::json::object();
        ap.rockTiles = tilesPath;
        ap.weights = false;
        ArchesResult ar;
        const double all = bestOf(1, [&] { ar = bakeStacks(ap, rocky, ArchesOutput::All, task); });
        std::printf("\n| rocks in rock layers (§5, Table 2) | rocks | rocks in the tile set | tile generation | instancing | whole bake |\n|---|---|---|---|---|---|\n");
        std::printf("| paper: cave / canyon / cliff | 1941 / 6113 / 2931 | 50 / 70 / 50 | 30.2 / 44.1 / 19.0 s | 0.6 / 0.9 / 0.4 s | |\n");
        std::printf("| 100 x 75 m strata, 0.5 m stacks, 1.5 m rock stratum | %zu | %zu | %.2f s | %.2f s | %.2f s |\n",
                    ar.rocksPlaced, tr.set.rocks.size(), gen, ar.rockSeconds, all);
        std::remove(tilesPath.c_str());
    }
    // Issue 18: one local edit of the stable scene with its stabilisation, beside a global
    // stabilisation of the same stacks (what a non-local edit would pay at least).
    {
        EditContext ctx;
        ctx.sigma = 0.5;
        const double top = 45.0; // the strata's mean top: targets are projected on the bedrock
        const nlohmann::json edits[] = {
            {{"tool", "sculpt"}, {"mode", "carve"}, {"radius", 20.0}, {"points", {{500.0, 375.0, top}}}},
            {{"tool", "sculpt"}, {"mode", "add"}, {"radius", 20.0}, {"strength", 3.0}, {"points", {{300.0, 200.0, top}}}},
            {{"tool", "deposit"}, {"center", {600.0, 400.0}}, {"radius", 20.0}, {"amount", 3.0}},
            {{"tool", "erode"}, {"mode", "collapse"}, {"center", {700.0, 300.0, top}}, {"radius", 20.0}, {"rho", 0.6}},
            {{"tool", "erode"}, {"mode", "surface"}, {"center", {200.0, 500.0, top}}, {"radius", 20.0}},
            // A 40 m crack, V 6 m wide and 8 m deep, and a 40 m tunnel 4 m across.
            {{"tool", "crack"}, {"nodes", {{400.0, 600.0}, {430.0, 625.0}}},
             {"profile", {{-3.0, 2.0}, {3.0, 2.0}, {0.0, -8.0}}}, {"spline", false}},
            {{"tool", "tunnel"}, {"nodes", {{800.0, 100.0, top - 12.0}, {840.0, 110.0, top - 12.0}}},
             {"profile", {{-2.0, -2.0}, {2.0, -2.0}, {2.0, 2.0}, {-2.0, 2.0}}}}};
        Stacks global;
        const double whole = bestOf(1, [&] { global = stabilizeStacks(stable, ReposeAngles(), task); });
        std::printf("\n| edit of the 1000 x 750 scene (R = 20 cells), with its stabilisation | time | target | stacks changed | moves | vs a global stabilisation (%.0f ms) |\n|---|---|---|---|---|---|\n",
                    whole * 1e3);
        for (const auto& e : edits) {
            EditStats es;
            const double t = bestOf(3, [&] {
                Stacks work = stable;
                es = applyEdit(work, e, 0, ctx, task);
            });
            std::string what = e.at("tool").get<std::string>() + " " + e.value("mode", std::string(""));
            if (e.value("strength", 1.0) != 1.0) what += " (strength 3)";
            std::printf("| %s | %.1f ms | <= 100 ms | %zu | %zu | %.2f |\n", what.c_str(), t * 1e3, es.stacks,
                        es.stabilize.moves, t / whole);
        }
    }
}


// Issue 18: each material-stack sample end to end (the shell script as a user runs it: the
// tools, their file I/O and the previews) at its default size, beside OpenVDB's
// createLevelSetSphere in this process: the samples' surface voxels per second over the
// sphere's (2 threads), a ratio that travels between machines.
void samplesGroup(bool quick)
{
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    size_t sphereVoxels = 0;
    const double sphere = bestOf(3, [&] {
        sphereVoxels = size_t(openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(2.0f, Vec3f(0), 0.01f, 3.0f)
                                  ->activeVoxelCount());
    });
    const double sphereRate = double(sphereVoxels) / sphere;
    struct Sample
    {
        const char* script;
        std::vector<const char*> outputs;
    };
    const Sample samples[] = {{"08_arches.sh", {"arches_strata.vdb", "arches_canyon.vdb"}},
                              {"09_arches_coast.sh", {"arches_coast.vdb"}},
                              {"10_arches_ravine.sh", {"arches_ravine.vdb"}},
                              {"11_arches_canyon_collapse.sh", {"arches_canyon_collapse.vdb"}}};
    const std::string out = "/tmp/rockvdb_bench_samples";
    std::printf("\n## arches samples end to end (scripts with their previews, default sizes, 2 threads)\n\n");
    std::printf("| sample | end to end | target | surface voxels | voxels/s | vs createLevelSetSphere (%.3g voxels/s) |\n"
                "|---|---|---|---|---|---|\n", sphereRate);
    for (const Sample& sm : samples) {
        if (quick && std::strcmp(sm.script, "09_arches_coast.sh") != 0) continue;
        const std::string cmd = "cd '" ROCKVDB_SOURCE_DIR "' && bash samples/" + std::string(sm.script) +
                                " '" ROCKVDB_BINARY_DIR "' " + out + " > /dev/null 2>&1";
        int rc = 0;
        const double t = bestOf(1, [&] { rc = std::system(cmd.c_str()); });
        if (rc != 0) {
            std::printf("| %s | failed (exit %d) | <= 60 s | | | |\n", sm.script, rc);
            continue;
        }
        size_t voxels = 0;
        for (const char* name : sm.outputs) {
            const openvdb::GridPtrVecPtr grids = readGrids(out + "/" + name); // (held: the loop reads it)
            for (const auto& g : *grids) {
                if (g->getName() == "surface") voxels += size_t(g->activeVoxelCount());
            }
        }
        std::printf("| %s | %.1f s | <= 60 s | %zu | %.3g | %.3f |\n", sm.script, t, voxels, double(voxels) / t,
                    double(voxels) / t / sphereRate);
    }
    std::filesystem::remove_all(out);
}

// Issue 37: game assets. (1) A 1 m fractal rock at 5 mm with Gabor ridges as one GLB (three
// LODs, 1024² normal and occlusion maps), beside tools::volumeToMesh of the same grid (the
// first step of any mesh asset). (2) 100 rocks of a rock pile (a tile set's rocks instanced on
// a slab) as 100 GLBs through runAssetEach, beside volumeToMesh of the whole pile.
void assetGroup(bool quick)
{
    using Clock = std::chrono::steady_clock;
    auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    auto meshTime = [](const openvdb::FloatGrid& g) {
        return bestOf(2, [&] {
            std::vector<openvdb::Vec3s> pts;
            std::vector<openvdb::Vec3I> tris;
            std::vector<openvdb::Vec4I> quads;
            openvdb::tools::volumeToMesh(g, pts, tris, quads, 0.0);
        });
    };
    std::printf("\n## asset: game assets (2 threads), reference: tools::volumeToMesh of the same grid\n\n");
    std::printf("| asset | full mesh | time | volumeToMesh | ratio | LOD: triangles, mean distance to the level set / Hausdorff, normals off with the map / without |\n");
    std::printf("|---|---|---|---|---|---|\n");
    fractal::FractalRockParams fp;
    fp.shape.levels = 3;
    fp.shape.seed = 5;
    fp.size = Vec3d(1.0, 0.8, 0.5);
    fp.voxelSize = quick ? 0.01 : 0.005;
    Task t0;
    const fractal::RockResult rock = fractal::runRock(fp, true, false, t0);
    BakeSettings bs;
    bs.voxelSize = fp.voxelSize;
    const BakeResult detailed = detail::detailLevelSet(rock.surface, detail::DetailParams::fromJson(
        {{"gabor-amplitude", 0.006}, {"gabor-frequency", 25.0}, {"direction-axis", {0, 0, 1}}}), bs);
    asset::AssetParams ap;
    ap.textureSize = quick ? 512 : 1024;
    asset::AssetInputs in;
    in.grid = detailed.surface;
    asset::AssetResult r;
    const double t = bestOf(quick ? 1 : 3, [&] {
        Task task;
        r = asset::runAsset(ap, in, task);
    });
    const double ref = meshTime(*detailed.surface);
    std::string lods;
    for (const auto& l : r.stats["lods"]) {
        char cell[160];
        std::snprintf(cell, sizeof cell, "%s%d: %.2f / %.2f mm, %.1f° / %.1f°", lods.empty() ? "" : "; ",
                      l["triangles"].get<int>(), l["mean_error"].get<double>() * 1e3,
                      l["hausdorff"].get<double>() * 1e3, l["normal_map_degrees"].get<double>(),
                      l["lod_normal_degrees"].get<double>());
        lods += cell;
    }
    std::printf("| 1 m fractal rock + Gabor at %.0f mm, LODs %s, %d² normal + occlusion maps | %zu triangles | %.2f s | %.2f s | %.1fx | %s |\n",
                fp.voxelSize * 1e3, ap.lods.c_str(), ap.textureSize,
                r.stats["full_triangles"].get<size_t>(), t, ref, t / ref, lods.c_str());
    std::printf("ratio asset vs volumeToMesh (1 m rock): %.1fx\n", t / ref);
    std::fflush(stdout);

    // 100 rocks of a pile, each its own asset
    // game-sized pile rocks: 1 to 4 seeds per 20 cm cell at 20 voxels per cell (1 cm)
    rockpile::RockTileParams tp;
    tp.n = 5;
    tp.seedsMin = 1;
    tp.seedsMax = 4;
    tp.voxelsPerCell = 20;
    const rockpile::TileSet set = rockpile::generateTiles(tp);
    auto slab = box(Vec3d(0.0), Vec3d(1.5, 1.5, 0.3));
    rockpile::PileParams pp;
    auto instances = rockpile::selectRocks(set, *slab, pp);
    instances.resize(std::min<size_t>(instances.size(), quick ? 20 : 100));
    const rockpile::Pile pile = rockpile::buildPile(set, instances, pp);
    asset::AssetParams each;
    each.lods = "1000,300,100";
    each.textureSize = 512;
    asset::AssetInputs pin;
    pin.grid = pile.surface;
    pin.ids = pile.rockId;
    const auto t1 = Clock::now();
    Task task;
    const asset::AssetSetResult set100 = asset::runAssetEach(each, pin, task);
    const double all = since(t1);
    const double pref = meshTime(*pile.surface);
    size_t bytes = 0;
    for (const auto& g : set100.glbs) bytes += g.second.size();
    std::printf("| %zu rocks of a pile (tile set n = 5, %.1f mm voxels) as %zu GLBs, LODs %s, %d² maps | - | %.2f s (%.2f s each) | %.2f s (whole pile) | %.0fx | %.1f MB in all |\n",
                instances.size(), set.params.voxelSize() * 1e3, set100.glbs.size(), each.lods.c_str(),
                each.textureSize, all, all / double(set100.glbs.size()), pref, all / pref, double(bytes) / 1e6);
    std::printf("assets per second (pile): %.1f\n", double(set100.glbs.size()) / all);

    // The same rocks as one GLB: each unique rock once, instanced (EXT_mesh_gpu_instancing).
    std::vector<asset::PilePoint> pts;
    for (const auto& in : instances) pts.push_back({int64_t(in.rock), in.position});
    const auto t2 = Clock::now();
    Task itask;
    const asset::PileInstances pi = asset::pileInstances(set, pts, 3.0, "the bench's pile", itask);
    const asset::AssetResult inst = asset::runAssetInstances(each, pi, nlohmann::json::object(), itask);
    const double ti = since(t2);
    std::printf("| the same %zu rocks as one GLB: %zu unique rocks instanced, LODs %s, %d² maps | - | %.2f s | %.2f s (whole pile) | %.0fx | %.1f MB |\n",
                pi.instances, pi.prototypes.size(), each.lods.c_str(), each.textureSize, ti, pref,
                ti / pref, double(inst.glb.size()) / 1e6);
}

int main(int argc, char** argv)
{
    initialize();
    bool quick = false;
    for (int i = 1; i < argc; ++i) quick = quick || std::strcmp(argv[i], "--quick") == 0;
    std::printf("allocator: %s (both sides of every ratio run in this process with it)\n\n",
                ROCKVDB_ALLOCATOR);
    bool all = true, wantFoundation = false, wantBlocks = false, wantAmplify = false,
         wantDetail = false, wantRockpile = false, wantFill = false, wantFractal = false,
         wantArches = false, wantSamples = false, wantAsset = false;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "foundation") == 0) { wantFoundation = true; all = false; }
        if (std::strcmp(argv[i], "blocks") == 0) { wantBlocks = true; all = false; }
        if (std::strcmp(argv[i], "amplify") == 0) { wantAmplify = true; all = false; }
        if (std::strcmp(argv[i], "detail") == 0) { wantDetail = true; all = false; }
        if (std::strcmp(argv[i], "rockpile") == 0) { wantRockpile = true; all = false; }
        if (std::strcmp(argv[i], "fill") == 0) { wantFill = true; all = false; }
        if (std::strcmp(argv[i], "fractal") == 0) { wantFractal = true; all = false; }
        if (std::strcmp(argv[i], "arches") == 0) { wantArches = true; all = false; }
        if (std::strcmp(argv[i], "samples") == 0) { wantSamples = true; all = false; }
        if (std::strcmp(argv[i], "asset") == 0) { wantAsset = true; all = false; }
    }
    if (all || wantFoundation) foundation(quick);
    if (all || wantBlocks) blocksGroup(quick);
    if (all || wantAmplify) amplifyGroup(quick);
    if (all || wantDetail) detailGroup(quick);
    if (all || wantRockpile) rockpileGroup(quick);
    if (all || wantFill) fillGroup(quick);
    if (all || wantFractal) fractalGroup(quick);
    if (all || wantArches) archesGroup(quick);
    if (all || wantSamples) samplesGroup(quick);
    if (all || wantAsset) assetGroup(quick);
    return 0;
}
