// SPDX-License-Identifier: Apache-2.0
#include "RockPile.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Points.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/GridField.h>
#include <rockvdb/core/GridUtil.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tree/LeafManager.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <optional>
#include <tuple>

namespace rockvdb {
namespace rockpile {

using openvdb::Coord;
using LeafT = openvdb::FloatTree::LeafNodeType;

namespace {

constexpr uint64_t kColourStream = 0xc0105;

int floorToInt(double v) { return int(std::floor(v)); }

std::vector<double> rockRadii(const TileSet& set)
{
    const int m = set.params.voxelsPerCell;
    std::vector<double> radius(set.rocks.size(), 0.0);
    for (size_t i = 0; i < set.rocks.size(); ++i) {
        const Rock& r = set.rocks[i];
        const Vec3d s = r.seed.p * double(m) - Vec3d(0.5);
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    if (r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)] <= 0.5f) continue;
                    radius[i] = std::max(radius[i], (r.origin.offsetBy(x, y, z).asVec3d() - s).length());
                }
        radius[i] = (radius[i] + 1.0) * set.params.voxelSize();
    }
    return radius;
}

} // namespace

double maxRockRadius(const TileSet& set)
{
    const std::vector<double> r = rockRadii(set);
    return r.empty() ? 0.0 : *std::max_element(r.begin(), r.end());
}

namespace {

double supportDepth(const TileSet& set)
{
    return 2.0 * maxRockRadius(set) + 4.0 * set.params.voxelSize();
}

} // namespace

FieldPtr levelSetSupport(openvdb::FloatGrid::ConstPtr grid, const TileSet& set)
{
    return levelSetField(std::move(grid), supportDepth(set));
}

FieldPtr loadSupport(const std::string& path, const TileSet& set, uint64_t seed,
                     const SupportOptions& options)
{
    std::string ext = path.substr(path.find_last_of('.') == std::string::npos ? path.size()
                                                                               : path.find_last_of('.'));
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (ext == ".vdb") return levelSetSupport(readLevelSet(path, options.grid), set);
    if (ext == ".json") {
        ExpressionContext ctx;
        const auto slash = path.find_last_of('/');
        ctx.baseDir = slash == std::string::npos ? "." : path.substr(0, slash);
        ctx.seed = seed;
        return fieldFromJson(readJsonFile(path), ctx);
    }
    if (ext == ".obj" || ext == ".stl" || ext == ".ply") {
        const Mesh mesh = readMesh(path, options.up);
        requireClosed(mesh, "rockpile: support " + path);
        openvdb::BBoxd box;
        for (const auto& q : mesh.points) box.expand(openvdb::Vec3d(q));
        const double voxel = std::max(set.params.voxelSize(), box.extents().length() / 256.0);
        const double depth = supportDepth(set);
        return levelSetField(meshToLevelSet(mesh, voxel, 3.0, std::ceil(depth / voxel) + 2.0), depth);
    }
    fail<ValueError>("rockpile: the support must be a .vdb level set, a .json expression or a "
                     ".obj/.stl/.ply mesh (got ", path, ")");
}

Vec3d voxelToWorld(const TileSet& set, const Vec3d& v)
{
    return v * set.params.voxelSize();
}

Vec3d seedWorld(const TileSet& set, const Rock& rock, const Coord& shift)
{
    const double m = double(set.params.voxelsPerCell);
    return voxelToWorld(set, rock.seed.p * m - Vec3d(0.5) + shift.asVec3d());
}

std::vector<Instance> selectRocks(const TileSet& set, const Field& support, const PileParams& p,
                                  PileStats* stats)
{
    Task task;
    return selectRocks(set, support, p, task, stats);
}

std::vector<Instance> selectRocks(const TileSet& set, const Field& support, const PileParams& p,
                                  Task& task, PileStats* stats)
{
    p.validate();
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    const RockTileParams& tp = set.params;
    const int n = tp.n, m = tp.voxelsPerCell, span = n * m;
    const double dx = tp.voxelSize();
    const BBoxd bb = support.bounds();
    if (!isBounded(bb)) fail<ValueError>("rockpile: the support must be bounded");
    // Supports are sampled at float positions and rocks placed in int32 voxels: beyond 2^20
    // voxels from the origin a float resolves less than 1/16 of a voxel (at 1e8 m, 8 m), so
    // the selection would be noise; refused instead of an empty or garbled pile.
    const double farthest = std::max({std::abs(bb.min()[0]), std::abs(bb.min()[1]), std::abs(bb.min()[2]),
                                      std::abs(bb.max()[0]), std::abs(bb.max()[1]), std::abs(bb.max()[2])});
    if (farthest / dx > double(1 << 20)) {
        fail<ValueError>("rockpile: the support reaches ", farthest, " m from the origin, beyond the ",
                         double(1 << 20) * dx, " m (2^20 voxels of ", dx,
                         " m) where positions stay precise; move it nearer the origin");
    }

    // Region look-up by (type, axes, colours).
    std::map<std::tuple<int, std::array<int, 3>, std::vector<int>>, size_t> regionOf;
    for (size_t i = 0; i < set.regions.size(); ++i) {
        const Region& r = set.regions[i];
        regionOf[{r.type, r.axes, r.colours}] = i;
    }
    const bool periodic = tp.tiling == Tiling::Periodic;
    auto colour = [&](const Coord& q) {
        return periodic ? 0 : int(random::hashCoord(p.seed, kColourStream, q[0], q[1], q[2]) & 1);
    };
    auto region = [&](int type, std::array<int, 3> axes, std::vector<int> cols) {
        auto it = regionOf.find({type, axes, cols});
        if (it == regionOf.end()) fail<ValueError>("rockpile: the tile set lacks a region the tiling needs");
        return it->second;
    };
    // Lattice points whose features can meet the support (rocks reach one cell past them).
    auto lattice = [&](double w) { return (w / dx + 0.5) / double(span); };
    Coord lo, hi;
    for (int a = 0; a < 3; ++a) {
        lo[a] = floorToInt(lattice(bb.min()[a])) - 1;
        hi[a] = floorToInt(lattice(bb.max()[a])) + 1;
    }
    if (double(hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]) > 1e7) {
        fail<ValueError>("rockpile: the support spans more than 10^7 cubes of ", tp.cubeSize,
                         " m; use a smaller support or larger cubes");
    }
    struct Feature { size_t region; Coord shift; };
    std::vector<Feature> features;
    for (int i = lo[0]; i <= hi[0]; ++i)
        for (int j = lo[1]; j <= hi[1]; ++j)
            for (int k = lo[2]; k <= hi[2]; ++k) {
                const Coord P(i, j, k), shift = scaled(P, span);
                if (periodic) {
                    features.push_back({0, shift});
                    continue;
                }
                features.push_back({region(3, {{1, 1, 1}}, {colour(P)}), shift});
                for (int e = 0; e < 3; ++e) {
                    Coord end = P;
                    end[e] += 1;
                    std::array<int, 3> axes{{1, 1, 1}};
                    axes[e] = 0;
                    features.push_back({region(2, axes, {colour(P), colour(end)}), shift});
                }
                for (int a = 0; a < 3; ++a) {
                    const int u = a == 0 ? 1 : 0, v = a == 2 ? 1 : 2;
                    Coord cu(0), cv(0);
                    cu[u] = 1;
                    cv[v] = 1;
                    std::array<int, 3> axes{{0, 0, 0}};
                    axes[a] = 1;
                    features.push_back({region(1, axes, {colour(P), colour(P + cu), colour(P + cv),
                                                         colour(P + cu + cv)}), shift});
                }
                std::vector<int> cols;
                for (int b = 0; b < 8; ++b) cols.push_back(colour(P + Coord((b >> 2) & 1, (b >> 1) & 1, b & 1)));
                features.push_back({region(0, {{0, 0, 0}}, cols), shift});
            }

    // Largest embedding radius: the farthest solid voxel from its seed, over the set.
    const std::vector<double> radius = rockRadii(set);
    const double rMax = radius.empty() ? 0.0 : *std::max_element(radius.begin(), radius.end());

    struct Candidate { size_t feature, rock; };
    std::vector<Candidate> candidates;
    for (size_t f = 0; f < features.size(); ++f) {
        for (size_t r : set.regions[features[f].region].rocks) {
            if (set.rocks[r].solidVoxels() > 0) candidates.push_back({f, r});
        }
    }
    std::vector<Instance> found(candidates.size());
    std::vector<uint8_t> keep(candidates.size(), 0), deep(candidates.size(), 0);
    parallelFor(task, candidates.size(), 64, [&](size_t c) {
        const Feature& f = features[candidates[c].feature];
        const size_t ri = candidates[c].rock;
        const Rock& r = set.rocks[ri];
        const Vec3d seed = seedWorld(set, r, f.shift);
        const double fs = support.eval(seed);
        // Supports are distances (or bounds of them, beyond a grid's band): a rock
        // whose seed is farther out than its radius has no anchor inside.
        if (fs > radius[ri]) return;
        if (p.dropDeep && fs < -2.0 * rMax) {
            deep[c] = 1;
            return;
        }
        size_t inside = fs < 0 ? 1 : 0, total = 1;
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    if (r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)] <= 0.5f) continue;
                    const Coord v = r.origin.offsetBy(x, y, z) + f.shift;
                    inside += support.eval(voxelToWorld(set, v.asVec3d())) < 0;
                    ++total;
                }
        const double fraction = double(inside) / double(total);
        if (fraction >= p.threshold) {
            keep[c] = 1;
            found[c] = {ri, f.region, f.shift, seed, fraction};
        }
    });
    std::vector<Instance> out;
    size_t dropped = 0;
    for (size_t c = 0; c < candidates.size(); ++c) {
        if (keep[c]) out.push_back(found[c]);
        dropped += deep[c];
    }
    if (stats) {
        stats->features = features.size();
        stats->candidates = candidates.size();
        stats->placed = out.size();
        stats->droppedDeep = dropped;
        stats->selectSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
    }
    return out;
}

Pile buildPile(const TileSet& set, std::vector<Instance> instances, const PileParams& p)
{
    Task task;
    return buildPile(set, std::move(instances), p, task);
}

Pile buildPile(const TileSet& set, std::vector<Instance> instances, const PileParams& p,
               Task& task)
{
    p.validate();
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    const double dx = set.params.voxelSize();
    const float bg = float(p.halfWidth * dx);
    Pile pile;
    pile.instances = std::move(instances);
    const size_t count = pile.instances.size();
    // A chunk (core/Chunks.h) keeps the leaves inside its box of the whole pile's leaves.
    const ChunkSpec spec = p.chunking.spec("rockpile");
    std::optional<openvdb::CoordBBox> keep;
    if (spec.active() || planRequested()) {
        std::vector<openvdb::CoordBBox> bounds(count);
        openvdb::CoordBBox whole;
        for (size_t i = 0; i < count; ++i) {
            bounds[i] = rockLeafBounds(set.rocks[pile.instances[i].rock], pile.instances[i].shift,
                                       p.halfWidth);
            if (!bounds[i].empty()) whole.expand(bounds[i]);
        }
        reportPlanIfRequested("rockpile", whole, dx, spec, [&](const openvdb::CoordBBox& box) {
            // Each rock's band (its box's area times the band, surface and id leaves) in the
            // share of its box inside @a box.
            double bytes = 0;
            for (const auto& b : bounds) {
                if (b.empty() || !b.hasOverlap(box)) continue;
                openvdb::CoordBBox in = b;
                in.intersect(box);
                const auto e = b.extents();
                const double area = 2.0 * (double(e[0]) * e[1] + double(e[1]) * e[2] + double(e[2]) * e[0]);
                bytes += area * 2.0 * p.halfWidth * 2.0 * sizeof(float) * 1.5 *
                         double(in.volume()) / double(b.volume());
            }
            return bytes;
        });
        if (spec.active()) keep = chunkBox(whole, chunkDims(spec, whole), spec.index);
    }
    std::vector<std::vector<LeafT*>> leaves(count);
    try {
        parallelFor(task, count, 8, [&](size_t i) {
            const Instance& in = pile.instances[i];
            const Rock& rock = set.rocks[in.rock];
            if (keep && !rockLeafBounds(rock, in.shift, p.halfWidth).hasOverlap(*keep)) return;
            leaves[i] = rockLeavesShifted(rock, dx, in.shift, p.halfWidth);
            if (keep) {
                auto& list = leaves[i];
                auto end = std::remove_if(list.begin(), list.end(), [&](LeafT* leaf) {
                    if (keep->isInside(leaf->origin())) return false;
                    delete leaf;
                    return true;
                });
                list.erase(end, list.end());
            }
        });
    } catch (...) {
        for (auto& list : leaves)
            for (LeafT* leaf : list) delete leaf;
        throw;
    }
    // Leaves of neighbouring rocks meet: group them by origin and unite (min), the id going
    // to the rock that gives the minimum (the first, on ties).
    struct Piece { Coord origin; size_t instance; LeafT* leaf; };
    std::vector<Piece> pieces;
    for (size_t i = 0; i < count; ++i)
        for (LeafT* l : leaves[i]) pieces.push_back({l->origin(), i, l});
    std::sort(pieces.begin(), pieces.end(), [](const Piece& a, const Piece& b) {
        return a.origin != b.origin ? a.origin < b.origin : a.instance < b.instance;
    });
    std::vector<size_t> starts;
    for (size_t i = 0; i < pieces.size(); ++i) {
        if (i == 0 || pieces[i].origin != pieces[i - 1].origin) starts.push_back(i);
    }
    starts.push_back(pieces.size());
    const size_t groups = starts.size() - 1;
    std::vector<LeafT*> surfaceLeaves(groups), idLeaves(groups);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 64),
        [&](const tbb::blocked_range<size_t>& r) {
            for (size_t g = r.begin(); g != r.end(); ++g) {
                LeafT* base = pieces[starts[g]].leaf;
                auto* ids = new LeafT(base->origin(), -1.0f);
                float* v = base->buffer().data();
                float* id = ids->buffer().data();
                std::fill(id, id + LeafT::SIZE, -1.0f);
                const float first = float(pieces[starts[g]].instance);
                for (openvdb::Index q = 0; q < LeafT::SIZE; ++q) id[q] = first;
                for (size_t k = starts[g] + 1; k < starts[g + 1]; ++k) {
                    const float* w = pieces[k].leaf->buffer().data();
                    const float inst = float(pieces[k].instance);
                    for (openvdb::Index q = 0; q < LeafT::SIZE; ++q) {
                        if (w[q] < v[q]) {
                            v[q] = w[q];
                            id[q] = inst;
                        }
                    }
                    delete pieces[k].leaf;
                }
                auto& mask = base->getValueMask();
                for (openvdb::Index q = 0; q < LeafT::SIZE; ++q) {
                    const bool on = std::abs(v[q]) < bg;
                    mask.set(q, on);
                    if (!on) {
                        v[q] = v[q] < 0 ? -bg : bg;
                        id[q] = -1.0f;
                    }
                }
                ids->getValueMask() = mask;
                surfaceLeaves[g] = base;
                idLeaves[g] = ids;
            }
        });
    auto xf = openvdb::math::Transform::createLinearTransform(dx);
    pile.surface = emptyLevelSet("surface", xf, bg);
    pile.rockId = emptyAttribute("rock_id", xf->copy(), -1.0f);
    for (size_t g = 0; g < groups; ++g) {
        pile.surface->tree().addLeaf(surfaceLeaves[g]);
        pile.rockId->tree().addLeaf(idLeaves[g]);
    }
    openvdb::tools::signedFloodFill(pile.surface->tree());
    if (p.material >= 0) {
        pile.material = pile.rockId->deepCopy();
        pile.material->setName("material");
        const float id = float(p.material);
        openvdb::tree::LeafManager<openvdb::FloatTree> leaves(pile.material->tree());
        leaves.foreach([id](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
            for (auto it = leaf.beginValueOn(); it; ++it) it.setValue(id);
        });
    }
    pile.stats.placed = count;
    pile.stats.levelSetSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return pile;
}

openvdb::GridBase::Ptr instancePoints(const std::vector<Instance>& instances, const TileSet& set)
{
    // Library rocks are instanced by translation at library scale: orient is the identity,
    // pscale 1, variant the library rock (Houdini's Copy to Points picks piece `variant`) and
    // pivot its seed in the library, so a piece lands at P + (x − pivot).
    const std::vector<Vec3d> seeds = librarySeeds(set);
    InstancePoints p;
    std::vector<int32_t> rock, tile;
    for (const Instance& in : instances) {
        p.positions.push_back(in.position);
        p.orient.emplace_back(0.0f, 0.0f, 0.0f, 1.0f);
        p.pscale.push_back(1.0f);
        p.variant.push_back(int32_t(in.rock));
        p.pivot.emplace_back(seeds.at(in.rock));
        rock.push_back(int32_t(in.rock));
        tile.push_back(int32_t(in.region));
    }
    p.ints = {{"rock", std::move(rock)}, {"tile", std::move(tile)}};
    return instancePointsGrid(p, set.params.voxelSize(), "rocks");
}

} // namespace rockpile
} // namespace rockvdb
