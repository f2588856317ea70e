// SPDX-License-Identifier: Apache-2.0
// Rock tiles: the tile set — its regions (corner cubes: vertex, edge, face and centre regions
// for every colouring; periodic: one cube) and their rocks, made in parallel.
#include "RockTiles.h"

#include <rockvdb/core/GridUtil.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>

namespace rockvdb {
namespace rockpile {

using openvdb::Coord;

namespace {

struct Job
{
    size_t region;
    Coord cell;
    int index;
    Colouring colouring;
};

} // namespace

TileSet generateTiles(const RockTileParams& p)
{
    Task task;
    return generateTiles(p, task);
}

TileSet generateTiles(const RockTileParams& p, Task& task)
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

std::vector<Rock> cubeRocks(const RockTileParams& p, const Coord& cube, const Colouring& colouring)
{
    p.validate();
    std::vector<std::pair<Coord, int>> jobs;
    for (int i = 0; i < p.n; ++i)
        for (int j = 0; j < p.n; ++j)
            for (int k = 0; k < p.n; ++k) {
                const Coord c = scaled(cube, p.n) + Coord(i, j, k);
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

} // namespace rockpile
} // namespace rockvdb
