// SPDX-License-Identifier: Apache-2.0
#include "RockPileStage.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/VdbIO.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rockvdb {
namespace rockpile {

using nlohmann::json;

namespace {

Schema<RockTileParams> makeTilesSchema()
{
    using T = RockTileParams;
    Schema<T> s("rockpile", "Generate a rock tile set: cubes of n³ cells with seeds, each rock "
                            "the discrete anisotropic Voronoi cell of its seed, eroded except "
                            "near its contacts.");
    ParamInfo tiling = param("tiling", ParamType::Text, "", "aperiodic", Range::any(),
                           "aperiodic (2-colour corner cubes) or periodic (one cube, arches §5)");
    tiling.choices = {"aperiodic", "periodic"};
    s.add(tiling, [](const T& p) { return json(p.tiling == Tiling::Periodic ? "periodic" : "aperiodic"); },
          [](T& p, const json& j) { p.tiling = j == "periodic" ? Tiling::Periodic : Tiling::Aperiodic; });
    s.member(param("n", ParamType::Int, "cells", 5, Range::closed(3, 64),
                 "Cells per cube edge (aperiodic >= 4, periodic >= 3)"), &T::n);
    s.add(param("seeds-per-cell", ParamType::Ints, "", json::array({1, 1}), Range::closed(1, 64),
              "Seeds per cell n_k in [min, max] (s = max)", 2),
          [](const T& p) { return json::array({p.seedsMin, p.seedsMax}); },
          [](T& p, const json& j) { p.seedsMin = j.at(0); p.seedsMax = j.at(1); });
    s.member(param("anisotropy", ParamType::Reals, "", json::array({1.0, 1.0, 1.0}),
                 Range::openClosed(0, 100),
                 "alpha, beta, gamma: relative rock extents along each seed's random frame "
                 "(5,5,1: flat rocks)", 3), &T::anisotropy);
    s.member(param("anisotropy-jitter", ParamType::Real, "", 0.25, Range::halfOpen(0, 1),
                 "Each extent uniform in [v(1 - j), v]"), &T::anisotropyJitter);
    s.member(param("g-max", ParamType::Real, "", 2.0, Range::closed(1, 16),
                 "g_k uniform in [1, g-max] (relative rock size)"), &T::gMax);
    s.member(param("voxels-per-cell", ParamType::Int, "", 10, Range::closed(4, 64),
                 "m: n_G = m n voxels per cube edge"), &T::voxelsPerCell);
    s.member(param("cube-size", ParamType::Real, "m", 1.0, Range::above(0), "Cube edge"),
             &T::cubeSize);
    s.add(param("contact-radii", ParamType::Reals, "cells", json::array({0.08, 0.3}),
              Range::closed(0, 1.5), "a, b: no erosion within a of a contact, full beyond b", 2),
          [](const T& p) { return json::array({p.contactInner, p.contactOuter}); },
          [](T& p, const json& j) { p.contactInner = j.at(0); p.contactOuter = j.at(1); });
    s.member(param("erosion-steps", ParamType::Int, "", 6, Range::closed(0, 100),
                 "Spheroidal erosion iterations"), &T::erosionSteps);
    s.member(param("erosion-rate", ParamType::Real, "", 0.5, Range::openClosed(0, 1),
                 "Erosion per step at full exposure"), &T::erosionRate);
    s.member(param("poisson-radius", ParamType::Real, "cells", 0.0, Range::halfOpen(0, 1),
                 "Periodic: seed spacing (0 = 0.8; else >= 0.3)"), &T::poissonRadius);
    s.member(seedRow(), &T::seed);
    s.rule([](const T& p) {
        if (p.tiling == Tiling::Aperiodic && p.n < 4) {
            fail<ValueError>("rockpile: n must be >= 4 for aperiodic corner cubes (a cell's "
                             "owner must be unambiguous) (got ", p.n, ")");
        }
        if (p.seedsMax < p.seedsMin) {
            fail<ValueError>("rockpile: seeds-per-cell needs min <= max (got ", p.seedsMin, ", ",
                             p.seedsMax, ")");
        }
        if (!(p.contactOuter > p.contactInner)) {
            fail<ValueError>("rockpile: contact-radii need a < b (got a = ", p.contactInner,
                             ", b = ", p.contactOuter, ")");
        }
        if (p.tiling == Tiling::Periodic && p.poissonRadius > 0 && p.poissonRadius < 0.3) {
            fail<ValueError>("rockpile: poisson-radius must be 0 (default) or in [0.3, 1) (got ",
                             p.poissonRadius, ")");
        }
    });
    s.group("Erosion", {"contact-radii", "erosion-steps", "erosion-rate"});
    return s;
}

Schema<PileParams> makePileSchema()
{
    using P = PileParams;
    Schema<P> s("rockpile", "Fill a support object with a tile set's rocks.");
    s.member(param("threshold", ParamType::Real, "", 0.5, Range::openClosed(0, 1),
                 "Place a rock when this fraction of its anchors (voxel centres and seed) is "
                 "inside"), &P::threshold);
    s.add(param("keep-deep", ParamType::Bool, "", false, Range::any(),
              "Keep rocks deeper than twice the largest embedding radius (dropped by default)"),
          [](const P& p) { return json(!p.dropDeep); },
          [](P& p, const json& j) { p.dropDeep = !j.get<bool>(); });
    s.member(param("material", ParamType::Int, "", -1, Range::halfOpen(-1, 1 << 24),
                 "Also write grid 'material' holding this id on every rock voxel (to unite the "
                 "pile with other stages' material grids); -1 = none"), &P::material);
    s.add(param("support-grid", ParamType::Text, "", "", Range::any(),
              "Level set to read from a .vdb support (empty: 'surface', else the file's only "
              "level set)"),
          [](const P& p) { return json(p.support.grid); },
          [](P& p, const json& j) { p.support.grid = j.get<std::string>(); });
    ParamInfo up = param("up", ParamType::Text, "", "z", Range::any(),
                       "Up axis of a mesh support: z (rockvdb) or y (Blender's OBJ export "
                       "default, Houdini)");
    up.choices = {"z", "y"};
    s.add(up, [](const P& p) { return json(p.support.up == UpAxis::Y ? "y" : "z"); },
          [](P& p, const json& j) { p.support.up = j == "y" ? UpAxis::Y : UpAxis::Z; });
    s.member(seedRow("Lattice colours (and a JSON support's noise)"), &P::seed);
    addChunkRows(s, [](auto& p) -> auto& { return p.chunking; });
    s.group("Input", {"support-grid", "up"});
    return s;
}

} // namespace

const Schema<RockTileParams>& tilesSchema()
{
    static const Schema<RockTileParams> s = makeTilesSchema();
    return s;
}

const Schema<PileParams>& pileSchema()
{
    static const Schema<PileParams> s = makePileSchema();
    return s;
}

RockTileParams::RockTileParams() { tilesSchema().reset(*this); }
RockTileParams RockTileParams::fromJson(const json& j) { return tilesSchema().fromJson(j); }
json RockTileParams::toJson() const { return tilesSchema().toJson(*this); }
void RockTileParams::validate() const { tilesSchema().validate(*this); }

PileParams::PileParams() { pileSchema().reset(*this); }

void PileParams::validate() const
{
    pileSchema().validate(*this);
    require(halfWidth >= 1 && halfWidth <= 16, "rockpile", "half width (voxels)", "in [1, 16]",
            halfWidth);
}

double tilesBytes(const RockTileParams& p, bool library)
{
    const double n = p.n, inner = n - 2.0;
    const double cells = p.tiling == Tiling::Periodic
                             ? n * n * n
                             : 16.0 + 48.0 * inner + 96.0 * inner * inner + 256.0 * inner * inner * inner;
    const double m = p.voxelsPerCell;
    // Bytes per cell voxel at the peak RSS, measured at n = 6 and 10 (m = 10): 52 and 49
    // without the library (the rocks' dense boxes of ρ, their Voronoi scratch, the tile
    // grid beside them), 122 and 117 with it (the rocks' narrow bands and their atlas).
    const double perVoxel = library ? 124.0 : 52.0;
    return cells * m * m * m * perVoxel + 64e6;
}

TilesResult runTiles(const RockTileParams& params, bool library, Task& task, double maxMemoryBytes)
{
    params.validate();
    require(std::isfinite(maxMemoryBytes) && maxMemoryBytes >= 0, "rockpile", "max-memory",
            ">= 0 GB", maxMemoryBytes / 1e9);
    const double need = tilesBytes(params, library), limit = memoryLimitBytes(maxMemoryBytes);
    if (need > limit) {
        fail<ValueError>("rockpile: a tile set of n = ", params.n, " cells per cube edge at ",
                         params.voxelsPerCell, " voxels per cell needs about ", formatBytes(need),
                         ", over the ", formatBytes(limit), " allowed; use a smaller --n or "
                         "--voxels-per-cell, or raise --max-memory");
    }
    TilesResult r;
    // Shares measured at the defaults: Voronoi + erosion dominates; the library's level sets
    // take about as long again when asked for.
    task.phase("voronoi + erosion", library ? 0.45 : 0.9);
    r.set = generateTiles(params, task);
    task.phase("tile grid", library ? 0.05 : 0.1);
    r.rho = tileGrid(r.set, task);
    const json prov = {{"tiles", params.toJson()}};
    stampResult(r, kToolName, {r.rho}, prov);
    const RockTileStats& st = r.set.stats;
    char line[300];
    std::snprintf(line, sizeof line, "%zu stones (%zu regions, %zu seeds, %zu contacts); "
                  "seeds %.3f s, voronoi + erosion %.3f s", st.stones, st.regions, st.seeds,
                  st.contacts, st.seedSeconds, st.voronoiSeconds);
    r.report.push_back(line);
    if (library) {
        task.phase("level sets", 0.5);
        r.library = libraryGrid(r.set, task, 3.0, &r.librarySeconds, &r.libraryIds);
        stampExtras(r, kToolName, {r.libraryIds, r.library});
        std::snprintf(line, sizeof line, "level sets %.3f s", r.librarySeconds);
        r.report.push_back(line);
    }
    task.done();
    r.stats = {{"stones", st.stones}, {"regions", st.regions}, {"seeds", st.seeds},
               {"contacts", st.contacts}, {"seed_seconds", st.seedSeconds},
               {"voronoi_seconds", st.voronoiSeconds}, {"library_seconds", r.librarySeconds},
               {"phases", phasesJson(task)}};
    return r;
}

StageResult runLibrary(const TileSet& set, Task& task)
{
    StageResult r;
    task.phase("level sets", 1.0);
    openvdb::FloatGrid::Ptr ids;
    auto library = libraryGrid(set, task, 3.0, nullptr, &ids);
    stampResult(r, kToolName, {ids, library}, {{"tiles", set.params.toJson()}});
    task.done();
    r.stats = {{"phases", phasesJson(task)}};
    return r;
}

TileSet readTileSet(const std::string& path)
{
    const openvdb::GridPtrVecPtr grids = readGrids(path);
    for (const auto& g : *grids) {
        auto rho = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
        if (rho && rho->getName() == "rho") return tilesFromGrid(*rho, path);
    }
    fail<ValueError>("rockpile: ", path, " holds no tile set (grid 'rho')");
}

PileResult pileRocks(const TileSet& tiles, const Field& support, const PileParams& params,
                     const json& inputs, bool points, bool library, Task& task)
{
    params.validate();
    if (params.chunking.spec("rockpile").active() && (points || library)) {
        fail<ValueError>("rockpile: --points and --library describe the whole pile; write them "
                         "from a bake without --chunk");
    }
    PileResult r;
    task.phase("select", 0.3);
    auto instances = selectRocks(tiles, support, params, task, &r.counts);
    task.phase("level sets", library ? 0.5 : 0.7);
    r.pile = buildPile(tiles, std::move(instances), params, task);
    r.counts.levelSetSeconds = r.pile.stats.levelSetSeconds;
    const json prov = {{"pile", stageProvenance(pileSchema().toJson(params), inputs)}};
    openvdb::GridPtrVec grids{r.pile.surface, r.pile.rockId};
    if (r.pile.material) grids.push_back(r.pile.material);
    stampResult(r, kToolName, grids, prov);
    if (points) {
        r.points = instancePoints(r.pile.instances, tiles);
    }
    if (library) {
        task.phase("library", 0.2);
        r.library = libraryGrid(tiles, task, 3.0, nullptr, &r.libraryIds);
    }
    stampExtras(r, kToolName, {r.points, r.libraryIds, r.library});
    task.done();
    return r;
}

PileResult runPile(const PileParams& params, const PileInputs& in, Task& task)
{
    params.validate();
    json inputs = json::object();
    TileSet set;
    if (in.tilesGrid) {
        inputs["tiles"] = gridSource(*in.tilesGrid);
        set = tilesFromGrid(*in.tilesGrid);
    } else {
        inputs["tiles"] = in.tilesPath;
        set = readTileSet(in.tilesPath);
    }
    FieldPtr support;
    if (in.supportField) {
        support = in.supportField;
        inputs["support"] = in.supportExpression;
    } else if (in.supportGrid) {
        requireLevelSet(*in.supportGrid, "rockpile support");
        support = levelSetSupport(in.supportGrid, set);
        inputs["support"] = gridSource(*in.supportGrid);
    } else {
        support = loadSupport(in.supportPath, set, params.seed, params.support);
        inputs["support"] = in.supportPath;
    }
    PileResult r = pileRocks(set, *support, params, inputs, in.points, in.library, task);
    if (r.pile.surface->activeVoxelCount() == 0) {
        fail<ValueError>("rockpile: the result is empty (no active voxels): no rock of the tile "
                         "set lies in the support (is it smaller than a rock, or only a thin "
                         "shell?)");
    }
    const PileStats& s = r.counts;
    char line[300];
    std::snprintf(line, sizeof line,
                  "placed %zu rocks (%zu candidates in %zu tile features, %zu too deep); "
                  "select %.3f s, level sets %.3f s (%.0f rocks/s)",
                  s.placed, s.candidates, s.features, s.droppedDeep, s.selectSeconds,
                  s.levelSetSeconds,
                  double(s.placed) / std::max(1e-9, s.selectSeconds + s.levelSetSeconds));
    r.report.push_back(line);
    r.stats = {{"placed", s.placed}, {"candidates", s.candidates}, {"features", s.features},
               {"dropped_deep", s.droppedDeep}, {"select_seconds", s.selectSeconds},
               {"level_set_seconds", s.levelSetSeconds}, {"phases", phasesJson(task)}};
    return r;
}

} // namespace rockpile
} // namespace rockvdb
