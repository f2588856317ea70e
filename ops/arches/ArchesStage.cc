// SPDX-License-Identifier: Apache-2.0
// The material-stack stage (see ArchesStage.h).
#include "ArchesStage.h"

#include <rockvdb/core/Points.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/arches/StackBuild.h>
#include <rockvdb/arches/StackFile.h>
#include <rockvdb/arches/Weights.h>
#include <rockvdb/rockpile/RockPileStage.h>

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/GridCsg.h>
#include <rockvdb/core/GridField.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/VdbIO.h>

#include <algorithm>
#include <cstdio>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>

namespace rockvdb {
namespace arches {

using json = nlohmann::json;

namespace {

// σ of the convolution surfaces and the edits: the sigma row, unset half the cell size.
double sigmaOf(const ArchesParams& p, const StackGeometry& g) { return p.sigma.value_or(0.5 * g.cell); }

// The level sets' reconstruction (StackBake.h): the kernel row, and interpolate's reach R,
// unset kDefaultReachCells (a 2 m reach at the samples' 0.5 m cells: planar walls up to ~70°).
void kernelOf(const ArchesParams& p, const StackGeometry& g, SkeletonBake& b)
{
    b.kernel = p.kernel == "box" ? Kernel::Box : Kernel::Interpolate;
    b.reach = b.kernel == Kernel::Box ? 0.0 : p.reach.value_or(kDefaultReachCells * g.cell);
}

} // namespace

namespace {

template<typename T>
void row(Schema<ArchesParams>& s, ParamInfo info, T ArchesParams::*m)
{
    s.member(std::move(info), m);
}

Schema<ArchesParams> makeArchesSchema()
{
    using P = ArchesParams;
    Schema<P> s("arches", "Material-stack terrain (arches §3): stacks of sand, bedrock, rocks, water "
                          "and air layers from a heightfield, procedural strata or any solid, "
                          "stabilised at the repose angles and baked as level sets interpolated between the stacks "
                          "(or the §3.3 convolution surface: kernel box).");
    row(s, param("terrain", ParamType::Json, "", json(), Range::any(),
                 "The initial terrain: a heightfield expression node (heightfield, noise_terrain, "
                 "sea_cliff), {\"type\": \"strata\", ...}, {\"type\": \"level_set\", \"file\": ...} or any "
                 "solid expression (JSON, or the path of a JSON file)"),
        &P::terrain);
    row(s, param("extent", ParamType::Reals, "m", json(), Range::any(),
                 "xmin, ymin, xmax, ymax of a solid terrain's stacks (unset: the solid's bounds)", 4),
        &P::extent);
    row(s, param("cell-size", ParamType::Real, "m", json(), Range::above(0),
                 "Stack size s (unset: a heightfield's sample spacing, else 1 m)"),
        &P::cellSize);
    row(s, param("floor", ParamType::Real, "m", json(), Range::any(),
                 "Bottom z0 of every stack (unset: the terrain's bottom)"),
        &P::floor);
    row(s, param("quantum", ParamType::Real, "m", 0.01, Range::above(0),
                 "Thickness unit q: layers are whole multiples of it (exact mass accounting)"),
        &P::quantum);
    row(s, param("sand-depth", ParamType::Real, "m", 0.0, Range::atLeast(0),
                 "Sand laid on a heightfield terrain"),
        &P::sandDepth);
    row(s, param("sand-map", ParamType::Text, "", "", Range::any(),
                 "Image (EXR / 16-bit PNG, one pixel per heightfield sample, pixel row = sample row) "
                 "whose value 0..1 scales sand-depth per stack (\"\" = sand-depth everywhere)"),
        &P::sandMap);
    row(s, param("sigma", ParamType::Real, "m", json(), Range::above(0),
                 "Half size σ of the convolution's cubic kernel (§3.3; unset: half the cell size)"),
        &P::sigma);
    ParamInfo kernel = param("kernel", ParamType::Text, "", "interpolate", Range::any(),
                             "How the level sets are made from the stacks: interpolate = the stacks' "
                             "vertical distances to their layer boundaries, clamped to reach (to σ near "
                             "features thinner than reach) and blended by the xy kernel: planar walls at "
                             "any angle to the stack grid; box = the convolution of §3.3 as written "
                             "(walls steeper than σ per cell are stair-stepped)");
    kernel.choices = {"interpolate", "box"};
    row(s, kernel, &P::kernel);
    row(s, param("reach", ParamType::Real, "m", json(), Range::above(0),
                 "Vertical reach R of the interpolate kernel: walls stay planar where the stacks "
                 "under the kernel differ by less than R in height (unset: 4 cells)"),
        &P::reach);
    row(s, voxelSizeRow(json(), "Voxel edge of the level sets (unset: the cell size)"),
        &P::voxelSize);
    row(s, halfWidthRow(defaultHalfWidth()),
        &P::halfWidth);
    row(s, param("repose-sand", ParamType::Real, "degrees", ReposeAngles().sand, Range::open(0, 90),
                 "Repose angle of sand (§3.4: 30-35)"),
        &P::reposeSand);
    row(s, param("repose-rocks", ParamType::Real, "degrees", ReposeAngles().rocks, Range::open(0, 90),
                 "Repose angle of rocks (§3.4: 40-45)"),
        &P::reposeRocks);
    row(s, param("stabilize", ParamType::Bool, "", true, Range::any(),
                 "Merge, sort and slide the granular layers to rest before baking (§3.4)"),
        &P::stabilize);
    row(s, param("weights", ParamType::Bool, "", true, Range::any(),
                 "Also write weight_<material> fog grids: the share of each ground material's visible faces "
                 "around every band voxel (§6), for shaders to blend textures by"),
        &P::weights);
    row(s, param("rock-tiles", ParamType::Text, "", "", Range::any(),
                 "A rock tile set (.vdb of vdb_rockpile tiles): its rocks are instanced where at least "
                 "rock-threshold of their anchors (seed and solid voxels) lie in rock layers, buried ones dropped, "
                 "and united with the ground (§5 keeps a rock whose seed lies in a rock layer: half a rock could "
                 "then stand out of a thin layer; \"\" = rock layers stay a material surface)"),
        &P::rockTiles);
    row(s, param("rock-threshold", ParamType::Real, "", 0.5, Range::openClosed(0, 1),
                 "Share of a rock's anchors (its seed and solid voxels) that must lie in rock layers for it to "
                 "be instanced"),
        &P::rockThreshold);
    row(s, param("material-ids", ParamType::Ints, "", json::array({int(Material::Sand), int(Material::Bedrock),
                                                                    int(Material::Rocks)}),
                 Range::closed(0, (1 << 24) - 1),
                 "Ids the 'material' grid holds for sand, bedrock and rocks (e.g. ids not taken by the grids "
                 "this terrain is united with)", 3),
        &P::materialIds);
    row(s, param("edits", ParamType::Json, "", json::array(), Range::any(),
                 "Edits applied in order after stabilisation (§4): a list of {\"tool\": sculpt | crack | tunnel | deposit | erode | "
                 "stabilize, ...} (JSON, or the path of a JSON file); each is stabilised locally"),
        &P::edits);
    row(s, seedRow("Seed of noise terrains and warps"), &P::seed);
    row(s, maxMemoryRow(), &P::maxMemoryGB);
    addChunkRows(s, [](auto& p) -> auto& { return p.chunking; });
    s.rule([](const P& p) {
        if (p.reach && p.kernel == "box") fail<ValueError>("arches: reach is the interpolate kernel's; kernel box has none");
        if (p.terrain.is_null()) fail<ValueError>("arches: terrain is required (a heightfield, strata, level_set or solid node)");
        const json edits = jsonOrFile(p.edits);
        if (!edits.is_array()) fail<ValueError>("arches: edits must be a list of edits [{\"tool\": ...}, ...]");
        for (size_t k = 0; k < edits.size(); ++k) validateEdit(edits[k], k);
    });
    // Front-ends' groups (the Blender add-on's sub-panels) and file rows.
    s.group("Input", {"terrain", "extent", "cell-size", "floor"});
    s.group("Materials", {"quantum", "sand-depth", "sand-map", "repose-sand", "repose-rocks",
                          "stabilize", "rock-tiles", "rock-threshold", "material-ids", "weights"});
    s.group("Surface", {"sigma", "kernel", "reach"});
    s.group("Edits", {"edits"});
    s.files({"sand-map", "rock-tiles"});
    return s;
}

double cellOf(const ArchesParams& p, double fallback) { return p.cellSize.value_or(fallback); }

json at(const json& node, const char* key, const std::string& path)
{
    if (!node.contains(key)) fail<ValueError>("arches: ", path, ".", key, " is required");
    return node.at(key);
}

Stacks strataStacks(const ArchesParams& p, const json& node, Task& task)
{
    static const std::vector<std::string> keys = {"type", "samples", "layers", "base", "amplitude", "frequency",
                                                  "warp", "warp_frequency", "octaves", "seed"};
    for (auto it = node.begin(); it != node.end(); ++it) {
        if (std::find(keys.begin(), keys.end(), it.key()) == keys.end()) {
            fail<ValueError>("arches: terrain.", it.key(), " is not a key of a strata terrain");
        }
    }
    StrataSpec spec;
    try {
        const json samples = at(node, "samples", "terrain");
        if (!samples.is_array() || samples.size() != 2) fail<ValueError>("arches: terrain.samples must be [nx, ny]");
        spec.geometry.nx = samples.at(0).get<int>();
        spec.geometry.ny = samples.at(1).get<int>();
        spec.geometry.cell = cellOf(p, 1.0);
        spec.geometry.z0 = p.floor.value_or(0.0);
        spec.geometry.quantum = p.quantum;
        const json layers = at(node, "layers", "terrain");
        if (!layers.is_array() || layers.empty()) fail<ValueError>("arches: terrain.layers must be a non-empty list");
        for (size_t k = 0; k < layers.size(); ++k) {
            const std::string path = "terrain.layers[" + std::to_string(k) + "]";
            requireKnownKeys(layers[k], {"material", "thickness"}, "arches", path);
            Stratum st;
            st.material = materialFromName(at(layers[k], "material", path).get<std::string>(), path + ".material");
            st.thickness = at(layers[k], "thickness", path).get<double>();
            if (!(st.thickness >= 0) || !std::isfinite(st.thickness)) {
                fail<ValueError>("arches: ", path, ".thickness must be >= 0 (got ", st.thickness, ")");
            }
            spec.strata.push_back(st);
        }
        spec.base = node.value("base", spec.base);
        spec.amplitude = node.value("amplitude", spec.amplitude);
        spec.frequency = node.value("frequency", spec.frequency);
        spec.warp = node.value("warp", spec.warp);
        spec.warpFrequency = node.value("warp_frequency", spec.warpFrequency);
        spec.octaves = node.value("octaves", spec.octaves);
        spec.seed = node.value("seed", uint64_t(p.seed));
    } catch (const json::exception& e) {
        fail<ValueError>("arches: terrain: a strata value has the wrong type (", e.what(), ")");
    }
    return stacksFromStrata(spec, task);
}

/// The material grid's ids (the Material enum's values) as the table's material-ids say.
void relabelMaterials(openvdb::FloatGrid& ids, const std::array<int, 3>& to, Task& task)
{
    std::array<float, kMaterialCount> map;
    for (int m = 0; m < kMaterialCount; ++m) map[size_t(m)] = float(m);
    map[size_t(Material::Sand)] = float(to[0]);
    map[size_t(Material::Bedrock)] = float(to[1]);
    map[size_t(Material::Rocks)] = float(to[2]);
    std::vector<openvdb::FloatTree::LeafNodeType*> leaves;
    ids.tree().getNodes(leaves);
    parallelFor(task, leaves.size(), 8, [&](size_t l) {
        for (auto it = leaves[l]->beginValueOn(); it; ++it) {
            const float v = *it;
            if (v >= 0.0f && v < float(kMaterialCount)) it.setValue(map[size_t(v)]);
        }
    });
}

} // namespace

const Schema<ArchesParams>& archesSchema()
{
    static const Schema<ArchesParams> s = makeArchesSchema();
    return s;
}

ArchesParams::ArchesParams() { archesSchema().reset(*this); }

json readScene(const std::string& path, std::string& baseDir)
{
    json scene = readJsonFile(path);
    if (!scene.is_object()) fail<ValueError>("arches: ", path, " must hold a JSON object of the table's keys");
    baseDir = std::filesystem::path(path).parent_path().string();
    if (baseDir.empty()) baseDir = ".";
    return scene;
}

void anchorGivenPaths(json& given)
{
    for (const char* key : {"rock-tiles", "sand-map"}) {
        if (!given.contains(key) || !given.at(key).is_string()) continue;
        const std::string v = given.at(key).get<std::string>();
        if (!v.empty() && v[0] != '/') given[key] = std::filesystem::absolute(v).string();
    }
}

Stacks buildStacks(const ArchesParams& p, Task& task, openvdb::FloatGrid::ConstPtr grid)
{
    archesSchema().validate(p);
    task.phase("stacks", 1.0);
    const json node = jsonOrFile(p.terrain);
    if (!node.is_object()) fail<ValueError>("arches: terrain must be a JSON object (a terrain node)");
    const std::string type = node.value("type", std::string());
    if (!p.sandMap.empty() && type != "heightfield" && type != "noise_terrain" && type != "sea_cliff") {
        fail<ValueError>("arches: sand-map needs a heightfield terrain (heightfield, noise_terrain or sea_cliff)");
    }
    if (type == "strata") return strataStacks(p, node, task);
    ExpressionContext ctx;
    ctx.baseDir = p.baseDir;
    ctx.seed = uint64_t(p.seed);
    // A heightfield node: one stack per sample.
    if (auto hf = heightfieldFromJson(node, ctx)) {
        if (p.cellSize && *p.cellSize != hf->heightfield->cellSize) {
            fail<ValueError>("arches: cell-size ", *p.cellSize, " differs from the heightfield's sample spacing ",
                             hf->heightfield->cellSize, " (leave it unset)");
        }
        double low = std::numeric_limits<double>::max();
        for (float z : hf->heightfield->z) low = std::min(low, double(z));
        const double z0 = p.floor.value_or(low - hf->baseDepth);
        if (p.sandMap.empty()) return stacksFromHeightfield(*hf->heightfield, p.quantum, z0, p.sandDepth, nullptr, task);
        std::string file = p.sandMap;
        if (file[0] != '/') file = p.baseDir + "/" + file;
        const GrayImage map = readGrayImage(file, "arches: sand-map");
        const Heightfield& h = *hf->heightfield;
        if (map.width != h.nx || map.height != h.ny) {
            fail<ValueError>("arches: sand-map ", p.sandMap, " is ", map.width, " x ", map.height,
                             " pixels; the heightfield has ", h.nx, " x ", h.ny, " samples");
        }
        std::vector<float> depth(map.pixels.size());
        for (size_t k = 0; k < depth.size(); ++k) {
            const float v = map.pixels[k];
            if (!(v >= 0.0f && v <= 1.0f)) {
                fail<ValueError>("arches: sand-map ", p.sandMap, " has a value outside 0..1 (", v, ") at pixel (",
                                 k % size_t(map.width), ", ", k / size_t(map.width), ")");
            }
            depth[k] = float(double(v) * p.sandDepth);
        }
        return stacksFromHeightfield(h, p.quantum, z0, p.sandDepth, &depth, task);
    }
    // A solid: a level set file, or any expression.
    FieldPtr solid;
    if (grid && type != "level_set") fail<ValueError>("arches: a terrain grid needs a level_set terrain node");
    if (type == "level_set") {
        // "source" records where a grid given in memory came from (Python); it is not read.
        for (auto it = node.begin(); it != node.end(); ++it) {
            if (it.key() != "type" && it.key() != "file" && it.key() != "grid" && it.key() != "source") {
                fail<ValueError>("arches: terrain.", it.key(), " is not a key of a level_set terrain (file, grid)");
            }
        }
        if (grid) {
            requireLevelSet(*grid, "arches terrain");
            solid = levelSetField(grid);
        } else {
            std::string file = at(node, "file", "terrain").get<std::string>();
            if (!file.empty() && file[0] != '/') file = p.baseDir + "/" + file;
            solid = levelSetField(readLevelSet(file, node.value("grid", std::string())));
        }
    } else {
        solid = fieldFromJson(node, ctx);
    }
    const BBoxd b = solid->bounds();
    if (!p.extent && !isBounded(b)) {
        fail<ValueError>("arches: the terrain solid is unbounded; give extent (xmin, ymin, xmax, ymax)");
    }
    const double cell = cellOf(p, 1.0);
    const std::array<double, 4> e = p.extent.value_or(std::array<double, 4>{b.min()[0], b.min()[1], b.max()[0], b.max()[1]});
    if (!(e[2] > e[0]) || !(e[3] > e[1])) fail<ValueError>("arches: extent must have xmax > xmin and ymax > ymin");
    StackGeometry g;
    g.cell = cell;
    g.x0 = e[0];
    g.y0 = e[1];
    const double nx = std::ceil((e[2] - e[0]) / cell), ny = std::ceil((e[3] - e[1]) / cell);
    if (!(nx * ny <= 1e10)) fail<ValueError>("arches: ", nx, " x ", ny, " stacks; use a larger cell-size or a smaller extent");
    g.nx = int(nx);
    g.ny = int(ny);
    g.z0 = p.floor.value_or(isBounded(b) ? b.min()[2] : 0.0);
    g.quantum = p.quantum;
    // Sample along the axes at a tenth of a cell, at least a quantum.
    return stacksFromSolid(*solid, g, std::max(p.quantum, 0.1 * cell), Material::Bedrock, task);
}

StabilizeStats stabilizeIfAsked(const ArchesParams& p, Stacks& stacks, Task& task)
{
    StabilizeStats st;
    if (!p.stabilize) return st;
    ReposeAngles a;
    a.sand = p.reposeSand;
    a.rocks = p.reposeRocks;
    stacks = stabilizeStacks(stacks, a, task, &st);
    return st;
}

ArchesOutput archesOutputFromString(const std::string& name, const std::string& what)
{
    if (name == "all") return ArchesOutput::All;
    if (name == "surface" || name == "ground") return ArchesOutput::Surface;
    if (name == "sand") return ArchesOutput::Sand;
    if (name == "bedrock") return ArchesOutput::Bedrock;
    if (name == "rocks") return ArchesOutput::Rocks;
    if (name == "water") return ArchesOutput::Water;
    if (name == "material") return ArchesOutput::Ids;
    if (name == "weights") return ArchesOutput::Weights;
    fail<ValueError>(what, " must be all, surface, ground, sand, bedrock, rocks, water, material or weights (got '", name, "')");
}

ArchesResult bakeStacks(const ArchesParams& p, const Stacks& stacks, ArchesOutput output, Task& task)
{
    archesSchema().validate(p);
    ArchesResult r;
    const auto& g = stacks.geometry();
    // §5: a tile set's rocks in the rock layers (at its voxel size unless one is given).
    std::optional<rockpile::TileSet> tiles;
    if (!p.rockTiles.empty() && stacks.volumeQuanta(Material::Rocks) > 0) {
        std::string file = p.rockTiles;
        if (file[0] != '/') file = p.baseDir + "/" + file;
        tiles = rockpile::readTileSet(file);
    }
    SkeletonBake b;
    b.sigma = sigmaOf(p, g);
    kernelOf(p, g, b);
    b.voxelSize = p.voxelSize.value_or(tiles ? tiles->params.voxelSize() : g.cell);
    const MaterialMask groundMask = tiles ? MaterialMask(maskOf(Material::Sand) | maskOf(Material::Bedrock)) : kGroundMask;
    b.halfWidth = p.halfWidth;
    b.maxMemoryBytes = p.maxMemoryGB * 1e9;
    // A chunk (core/Chunks.h) of the footprint, cut in x and y at multiples of the redistance's
    // 128-voxel sweep tiles (sweepTiled: a tile's values depend on its own leaves and a halo of
    // them alone). Everything is baked on the chunk grown by one sweep tile, the sweep halo and
    // the crossing search (so the tiles next to the chunk are exact too, which the weights'
    // gradients read), then cut back to the chunk: its voxels are the whole bake's.
    const ChunkSpec spec = p.chunking.spec("arches");
    std::optional<openvdb::CoordBBox> core;
    if (spec.active() || planRequested()) {
        if (spec.active() && tiles) {
            fail<ValueError>("arches: rock tiles are instanced over the whole rock layers; bake "
                             "with rock-tiles without --chunk");
        }
        const double dx = b.voxelSize, pad = b.sigma + (b.halfWidth + 2) * dx;
        const openvdb::CoordBBox whole(
            openvdb::Coord(int(std::floor((g.x0 - pad) / dx)), int(std::floor((g.y0 - pad) / dx)), 0),
            openvdb::Coord(int(std::ceil((g.x0 + g.nx * g.cell + pad) / dx)),
                           int(std::ceil((g.y0 + g.ny * g.cell + pad) / dx)), 0));
        const ChunkGrid grid{128, false};
        int grids = 1;
        for (Material m : {Material::Water, Material::Sand, Material::Bedrock, Material::Rocks}) {
            grids += stacks.volumeQuanta(m) > 0;
        }
        // A ground is about a height field: its xy voxels times the band, per level set (and
        // the convolution's wider band beside it).
        reportPlanIfRequested("arches", whole, dx, spec, [&](const openvdb::CoordBBox& box) {
            const double xy = double(box.dim()[0]) * box.dim()[1];
            return xy * 2.0 * std::max(b.halfWidth, b.sigma / dx + 2.0) * 2.0 * grids * 12.0;
        }, grid);
        if (spec.active()) {
            core = chunkBox(whole, chunkDims(spec, whole, grid), spec.index, grid);
            core->min()[2] = -(1 << 29);
            core->max()[2] = 1 << 29;
            const int w = int(std::ceil(b.halfWidth));
            const int halo = 8 * ((w + 2 + 7) / 8);
            const int grow = (128 + halo + w + 2 + 7) / 8 * 8;
            openvdb::CoordBBox reach = *core;
            reach.min() -= openvdb::Coord(grow, grow, 0);
            reach.max() += openvdb::Coord(grow, grow, 0);
            b.box = reach;
        }
    }
    const auto t1 = std::chrono::steady_clock::now();
    const bool all = output == ArchesOutput::All;
    // §6: the ground is one convolution over the union of sand, bedrock and rocks.
    const bool needGround = all || output == ArchesOutput::Surface || output == ArchesOutput::Ids ||
                            output == ArchesOutput::Weights;
    if (needGround) {
        r.surface = bakeSkeleton(Skeleton(stacks, groundMask), b, task);
        r.surface->setName("surface");
    }
    // One skeleton per material present (in id order): its level set, and all of them the ids.
    const std::pair<Material, ArchesOutput> kinds[] = {{Material::Water, ArchesOutput::Water},
                                                       {Material::Sand, ArchesOutput::Sand},
                                                       {Material::Bedrock, ArchesOutput::Bedrock},
                                                       {Material::Rocks, ArchesOutput::Rocks}};
    std::vector<Skeleton> skeletons;
    skeletons.reserve(4);
    std::vector<std::pair<Material, const Skeleton*>> parts;
    openvdb::FloatGrid::Ptr rockLayers; // the rocks' convolution level set, when §5 needs it
    for (const auto& [m, o] : kinds) {
        const bool ground = (maskOf(m) & groundMask) != 0;
        const bool wanted = output == o || (all && ground);
        if (output == ArchesOutput::Ids && ground && stacks.volumeQuanta(m) > 0) {
            skeletons.emplace_back(stacks, maskOf(m));
            parts.emplace_back(m, &skeletons.back());
        }
        if (!wanted) continue;
        if (stacks.volumeQuanta(m) == 0 && all) continue; // "all": the materials present
        skeletons.emplace_back(stacks, maskOf(m));
        auto grid = bakeSkeleton(skeletons.back(), b, task);
        grid->setName(materialName(m));
        r.materials.push_back(grid);
        if (ground) parts.emplace_back(m, &skeletons.back());
        if (m == Material::Rocks) rockLayers = grid;
    }
    // (With rock tiles the rocks are not in the ground's skeleton; the loop above baked their
    // level set only when asked for it.)
    const bool instance = tiles && (needGround || output == ArchesOutput::Rocks);
    if (instance && !rockLayers) {
        // (Baked as in the loop: the same bits as the rock layers' own level set.)
        rockLayers = bakeSkeleton(Skeleton(stacks, maskOf(Material::Rocks)), b, task);
    }
    if (all || output == ArchesOutput::Ids) {
        r.material = materialGrid(parts, b.sigma, *r.surface, task);
        relabelMaterials(*r.material, p.materialIds, task);
    }
    if (instance) {
        const auto t0 = std::chrono::steady_clock::now();
        rockpile::PileParams pp;
        pp.threshold = p.rockThreshold;
        pp.seed = uint64_t(p.seed);
        pp.material = p.materialIds[2];
        pp.halfWidth = p.halfWidth;
        const FieldPtr support = rockpile::levelSetSupport(rockLayers, *tiles);
        rockpile::PileResult pile = rockpile::pileRocks(*tiles, *support, pp, json::object(), false, false, task);
        r.rocksPlaced = pile.pile.instances.size();
        r.points = rockpile::instancePoints(pile.pile.instances, *tiles);
        openvdb::FloatGrid::Ptr rocks = pile.pile.surface;
        rocks->setName("rocks");
        // 'rocks' is now the instanced rocks' level set (the loop left the rock layers out of
        // "all": they are not ground here).
        r.materials.erase(std::remove_if(r.materials.begin(), r.materials.end(),
                                         [](const openvdb::FloatGrid::Ptr& x) { return x->getName() == "rocks"; }),
                          r.materials.end());
        if (all || output == ArchesOutput::Rocks) r.materials.push_back(rocks); // last: sand, bedrock, rocks
        if (needGround) {
            const std::vector<openvdb::FloatGrid::ConstPtr> both = {r.surface, rocks};
            auto united = csgGrids(CsgOp::Union, both);
            united->setName("surface");
            if (r.material) {
                r.material = csgAttribute(CsgOp::Union, both, {r.material, pile.pile.material}, *united, "material");
            }
            r.rockId = csgAttribute(CsgOp::Union, both, {nullptr, pile.pile.rockId}, *united, "rock_id");
            r.surface = united;
        }
        r.rockSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    // Rock tiles but no rock layers: no rocks, and points that say so.
    if (!p.rockTiles.empty() && (needGround || output == ArchesOutput::Rocks) && !r.points) {
        r.points = tiles ? rockpile::instancePoints({}, *tiles)
                         : instancePointsGrid(InstancePoints(), b.voxelSize, "rocks");
    }
    if ((all && p.weights) || output == ArchesOutput::Weights) {
        std::vector<Material> present;
        for (Material m : {Material::Sand, Material::Bedrock, Material::Rocks}) {
            if (stacks.volumeQuanta(m) > 0) present.push_back(m);
        }
        r.weights = visibleWeights(stacks, present, b.sigma, *r.surface, task);
    }
    if (core) {
        // Back to the chunk: level sets clipped (whole leaves: the chunk's faces are leaf
        // faces); the id and weight grids, which have no tiles and keep leaves without active
        // voxels (those of the surface's), lose only the leaves outside it (clip would prune
        // those inactive ones the whole bake keeps).
        auto keepInside = [&](openvdb::FloatGrid& grid) {
            std::vector<openvdb::Coord> outside;
            for (auto leaf = grid.tree().cbeginLeaf(); leaf; ++leaf) {
                if (!core->isInside(leaf->origin())) outside.push_back(leaf->origin());
            }
            for (const auto& o : outside) {
                delete grid.tree().stealNode<openvdb::FloatTree::LeafNodeType>(o, grid.background(), false);
            }
        };
        if (r.surface) r.surface->tree().clip(*core);
        for (auto& m : r.materials) m->tree().clip(*core);
        if (r.material) keepInside(*r.material);
        for (auto& w : r.weights) keepInside(*w);
    }
    r.stats.bakeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    r.stats.stacks = g.count();
    r.stats.layers = stacks.layerCount();
    r.stats.bytes = stacks.bytes();
    if (r.surface) r.stats.activeVoxels = size_t(r.surface->activeVoxelCount());
    return r;
}

EditContext editContext(const ArchesParams& p, const StackGeometry& g)
{
    EditContext c;
    c.sigma = sigmaOf(p, g);
    c.angles.sand = p.reposeSand;
    c.angles.rocks = p.reposeRocks;
    return c;
}

std::vector<EditStats> applyEdits(const ArchesParams& p, Stacks& stacks, const json& edits, size_t first, Task& task)
{
    const json list = jsonOrFile(edits);
    if (!list.is_array()) fail<ValueError>("arches: edits must be a list of edits [{\"tool\": ...}, ...]");
    std::vector<EditStats> out;
    const EditContext ctx = editContext(p, stacks.geometry());
    for (size_t k = 0; k < list.size(); ++k) {
        task.phase("edit", 1.0 / double(list.size()));
        out.push_back(applyEdit(stacks, list[k], first + k, ctx, task));
    }
    return out;
}

namespace {

// The one record on every grid a bake made: the table's values and the inputs.
void stamp(ArchesResult& r, const ArchesParams& p, const json& inputs)
{
    r.provenance = stageProvenance(archesSchema().toJson(p), inputs);
    openvdb::GridPtrVec all{r.surface, r.material, r.rockId, r.points};
    all.insert(all.end(), r.materials.begin(), r.materials.end());
    all.insert(all.end(), r.weights.begin(), r.weights.end());
    stampExtras(r, kToolName, all);
}

} // namespace

ArchesResult runStacks(const ArchesParams& p, Stacks stacks, Task& task)
{
    archesSchema().validate(p);
    const StabilizeStats st = stabilizeIfAsked(p, stacks, task);
    std::vector<EditStats> edits = applyEdits(p, stacks, p.edits, 0, task);
    ArchesResult r = bakeStacks(p, stacks, ArchesOutput::All, task);
    stamp(r, p, json::object());
    r.stats.stabilize = st;
    r.stats.edits = std::move(edits);
    r.stacks = std::move(stacks);
    return r;
}

namespace {

void requirePointsSource(const ArchesParams& p)
{
    if (p.rockTiles.empty()) {
        fail<ValueError>("arches: points need rock-tiles (the points are the rocks instanced "
                         "in rock layers)");
    }
}

// The rule of saved stacks (vdb_arches --from-stacks, Stacks.bake): a row that made the
// stacks cannot change; the bake's rows can, and edits can be added.
void requireBakeOnly(const std::string& row)
{
    const auto& rows = bakeOnlyRows();
    if (std::find(rows.begin(), rows.end(), row) == rows.end()) {
        fail<ValueError>("arches: ", row, " made the stacks; a bake of them may change only ",
                         bakeOnlyRowsText(), " (and add edits)");
    }
}

} // namespace

json savedScene(const std::string& paramsText, const std::string& path)
{
    const json scene = parseJsonOrDiscarded(paramsText);
    if (!scene.is_object()) {
        fail<IoError>("corrupt stacks file '", path, "': its parameters are not a JSON object");
    }
    try {
        (void)archesSchema().fromJson(scene);
    } catch (const ValueError& e) {
        fail<IoError>("corrupt stacks file '", path, "': parameters: ", e.what());
    }
    return scene;
}

Scene openScene(const SceneInputs& in, Task& task)
{
    if (!in.scenePath.empty() && !in.stacksPath.empty()) {
        fail<ValueError>("arches: give a scene or saved stacks, not both");
    }
    // The scene (or the saved stacks' scene), then the rows given on top.
    json scene = json::object();
    std::string baseDir = ".";
    std::optional<Stacks> saved;
    if (!in.scenePath.empty()) {
        scene = readScene(in.scenePath, baseDir);
    } else if (!in.stacksPath.empty()) {
        StackFile f = readStackFile(in.stacksPath);
        scene = savedScene(f.params, in.stacksPath);
        saved = std::move(f.stacks);
    }
    json given = in.given;
    if (in.anchorGiven) anchorGivenPaths(given); // the scene's own keys name files from its folder
    // Saved stacks were made by their scene: only the bake's rows may differ, and edits given
    // here come after the saved ones (the record lists both, so it replays).
    json more = json::array();
    for (auto it = given.begin(); it != given.end(); ++it) {
        if (saved && it.key() == "edits") {
            more = jsonOrFile(it.value());
            if (!more.is_array()) fail<ValueError>("arches: edits must be a list of edits");
            json all = jsonOrFile(scene.value("edits", json::array()));
            for (const auto& e : more) all.push_back(e);
            scene["edits"] = all;
            continue;
        }
        if (saved) requireBakeOnly(it.key());
        scene[it.key()] = it.value();
    }
    Scene out;
    out.params = archesSchema().fromJson(scene);
    out.params.baseDir = baseDir;
    out.params.edits = jsonOrFile(out.params.edits); // recorded as content, not a path
    const ArchesParams& p = out.params;
    if (in.points) requirePointsSource(p);
    if (in.terrainGrid) {
        out.inputs["terrain"] = jsonOrFile(p.terrain);
        out.inputs["terrain"]["source"] = gridSource(*in.terrainGrid);
    }
    if (saved) {
        out.stacks = std::move(*saved);
        out.edits = applyEdits(p, out.stacks, more, p.edits.size() - more.size(), task);
    } else {
        out.stacks = buildStacks(p, task, in.terrainGrid);
        out.stabilize = stabilizeIfAsked(p, out.stacks, task);
        out.edits = applyEdits(p, out.stacks, p.edits, 0, task);
    }
    return out;
}

ArchesResult bakeScene(const ArchesParams& params, const Stacks& stacks, const json& inputs,
                       const json& overrides, ArchesOutput output, bool points, Task& task)
{
    json rows = archesSchema().toJson(params);
    for (auto it = overrides.begin(); it != overrides.end(); ++it) {
        requireBakeOnly(it.key());
        rows[it.key()] = it.value();
    }
    ArchesParams p = archesSchema().fromJson(rows);
    p.baseDir = params.baseDir;
    if (points) requirePointsSource(p);
    if (points && (output == ArchesOutput::Sand || output == ArchesOutput::Bedrock ||
                   output == ArchesOutput::Water)) {
        fail<ValueError>("arches: points need a bake that instances the rocks (all, surface, "
                         "material, weights or rocks)");
    }
    ArchesResult r = bakeStacks(p, stacks, output, task);
    stamp(r, p, inputs);
    return r;
}

json stabilizeStatsJson(const StabilizeStats& s)
{
    return {{"visits", s.visits}, {"moves", s.moves}, {"moved_quanta", s.movedQuanta},
            {"seconds", s.seconds}};
}

json editStatsJson(const EditStats& e)
{
    return {{"tool", e.tool}, {"stacks", e.stacks}, {"window", {e.i0, e.j0, e.i1, e.j1}},
            {"bedrock_quanta", e.bedrock}, {"sand_quanta", e.sand}, {"rocks_quanta", e.rocks},
            {"stabilize", stabilizeStatsJson(e.stabilize)}, {"seconds", e.seconds}};
}

namespace {

// vdb_arches' lines on stderr and its --stats.
void tell(ArchesResult& r)
{
    const ArchesStats& s = r.stats;
    char line[240];
    std::snprintf(line, sizeof line, "%zu stacks, %zu layers in %.2f MB; stabilised in %.2f s "
                  "(%zu moves); baked in %.2f s, %zu active voxels",
                  s.stacks, s.layers, double(s.bytes) / 1e6, s.stabilize.seconds,
                  s.stabilize.moves, s.bakeSeconds, s.activeVoxels);
    r.report.push_back(line);
    if (r.rockId) {
        std::snprintf(line, sizeof line, "%zu rocks instanced in the rock layers in %.2f s",
                      r.rocksPlaced, r.rockSeconds);
        r.report.push_back(line);
    }
    const StackGeometry& g = r.stacks.geometry();
    const double m3 = g.quantum * g.cell * g.cell;
    json edits = json::array();
    for (size_t k = 0; k < s.edits.size(); ++k) {
        const EditStats& e = s.edits[k];
        std::snprintf(line, sizeof line, "edit %zu (%s): %zu stacks changed, bedrock %+.3g m3, "
                      "sand %+.3g m3, rocks %+.3g m3; %.3f s with its stabilisation (%zu moves)",
                      k, e.tool.c_str(), e.stacks, double(e.bedrock) * m3, double(e.sand) * m3,
                      double(e.rocks) * m3, e.seconds, e.stabilize.moves);
        r.report.push_back(line);
        edits.push_back(editStatsJson(e));
    }
    r.statsJson() = {{"stacks", s.stacks}, {"layers", s.layers}, {"bytes", s.bytes},
                      {"stabilize", stabilizeStatsJson(s.stabilize)}, {"edits", edits},
                      {"active_voxels", s.activeVoxels}, {"bake_seconds", s.bakeSeconds},
                      {"rocks_placed", r.rocksPlaced}};
}

} // namespace

ArchesResult runArches(const SceneInputs& inputs, Task& task)
{
    Scene scene = openScene(inputs, task);
    ArchesResult r = bakeScene(scene.params, scene.stacks, scene.inputs, json::object(),
                               ArchesOutput::All, inputs.points, task);
    r.stats.stabilize = scene.stabilize;
    r.stats.edits = std::move(scene.edits);
    r.stacks = std::move(scene.stacks);
    // The ids first and the ground last (vdb_tool acts on the last grid read).
    r.grids = {r.material};
    if (r.rockId) r.grids.push_back(r.rockId);
    for (const auto& g : r.weights) r.grids.push_back(g);
    for (const auto& g : r.materials) r.grids.push_back(g);
    r.grids.push_back(r.surface);
    tell(r);
    task.done();
    r.statsJson()["phases"] = phasesJson(task);
    return r;
}

const std::vector<std::string>& bakeOnlyRows()
{
    static const std::vector<std::string> rows = {"kernel", "reach", "voxel-size", "half-width", "max-memory", "weights",
                                                  "material-ids", "chunks", "chunk"};
    return rows;
}

std::string bakeOnlyRowsText()
{
    const auto& rows = bakeOnlyRows();
    std::string text;
    for (size_t k = 0; k < rows.size(); ++k) {
        text += (k == 0 ? "" : k + 1 == rows.size() ? " and " : ", ") + rows[k];
    }
    return text;
}

} // namespace arches
} // namespace rockvdb
