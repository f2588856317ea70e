// SPDX-License-Identifier: Apache-2.0
#include "Amplify.h"

#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridField.h>
#include <rockvdb/core/GridUtil.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Schema.h>

#include <nlohmann/json.hpp>

#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tree/LeafManager.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <tuple>
#include <vector>

namespace rockvdb {
namespace amplify {

using blocks::BlockTile;

namespace {

struct Cell
{
    int ix, iy, iz;
};

// The present flags of every examined (cell, block), in one dense table over the examined
// cells' box (its size is bounded before it is made): a lookup per candidate block and batch
// of the bake, so O(1).
class PresenceGrid final : public blocks::Presence
{
public:
    int lo[3] = {0, 0, 0}, dim[3] = {0, 0, 0};
    size_t blocks = 0;
    std::vector<uint8_t> flags; // [((ix - lo) · dim[1] + (iy - lo)) · dim[2] + (iz - lo)] · blocks + b
    bool sparse = false;        // then the cells with flags are these slots (increasing), a row each
    std::vector<size_t> slots;
    BBoxd box;
    bool any = false;

    size_t slot(int ix, int iy, int iz) const
    {
        return (size_t(ix - lo[0]) * size_t(dim[1]) + size_t(iy - lo[1])) * size_t(dim[2]) +
               size_t(iz - lo[2]);
    }
    bool present(int block, int ix, int iy, int iz) const override
    {
        // In 64 bits (no int overflow at extreme cells), unsigned: below lo wraps around.
        auto outside = [](int i, int l, int d) { return uint64_t(int64_t(i) - l) >= uint64_t(d); };
        if (outside(ix, lo[0], dim[0]) || outside(iy, lo[1], dim[1]) || outside(iz, lo[2], dim[2])) {
            return false;
        }
        size_t r = slot(ix, iy, iz);
        if (sparse) {
            const auto it = std::lower_bound(slots.begin(), slots.end(), r);
            if (it == slots.end() || *it != r) return false;
            r = size_t(it - slots.begin());
        }
        return flags[r * blocks + size_t(block)] != 0;
    }
    BBoxd bounds() const override { return any ? box : BBoxd(Vec3d(0), Vec3d(-1)); }
};

// f̃ = min(t, max(f, gap - t)): blocks replace the terrain's skin (the carving variant).
class Carved final : public Field
{
public:
    Carved(FieldPtr terrain, FieldPtr blocks, float gap)
        : mF(std::move(terrain)), mT(std::move(blocks)), mGap(gap) {}

    void evalBatch(const Batch& b, float* out) const override { eval(b, out, nullptr); }
    void evalIdBatch(const Batch& b, float* out, float* id) const override { eval(b, out, id); }
    BBoxd bounds() const override
    {
        BBoxd bb = mF->bounds();
        bb.expand(mT->bounds());
        return bb;
    }
    // min and max of ω-continuous functions are ω-continuous.
    double modulus(double r) const override { return std::max(mF->modulus(r), mT->modulus(r)); }
    double lipschitz() const override { return std::max(mF->lipschitz(), mT->lipschitz()); }
    bool exact() const override { return false; }

private:
    void eval(const Batch& b, float* out, float* id) const
    {
        alignas(64) float f[kMaxBatch], t[kMaxBatch];
        // The blocks are needed exactly where gap - t may exceed f: widen their band by the gap.
        Batch wide = b;
        wide.band = b.band + mGap;
        if (id) mT->evalIdBatch(wide, t, id);
        else mT->evalBatch(wide, t);
        mF->evalBatch(b, f);
        for (int i = 0; i < b.n; ++i) {
            const float carved = std::max(f[i], mGap - t[i]);
            if (id && !(t[i] < carved)) id[i] = kNoId;
            out[i] = std::min(t[i], carved);
        }
    }

    FieldPtr mF, mT;
    float mGap;
};

} // namespace

void PlacementRules::validate() const
{
    const char* op = "amplify";
    require(std::isfinite(distanceMin) && std::isfinite(distanceMax) && distanceMin <= distanceMax,
            op, "distance range", "finite with min <= max",
            std::to_string(distanceMin) + "," + std::to_string(distanceMax));
    require(std::isfinite(maxSlope) && maxSlope >= 0 && maxSlope <= 1, op, "max slope",
            "in [0, 1] (|g·u_z|)", maxSlope);
    require(anchors >= 1 && anchors <= 16, op, "anchors", "in [1, 16]", anchors);
    require(std::isfinite(fraction) && fraction >= 0 && fraction < 1, op, "fraction",
            "in [0, 1)", fraction);
    require(std::isfinite(maskCellSize) && maskCellSize > 0, op, "mask cell size", "> 0",
            maskCellSize);
}

double Strata::elevation(const Vec3d& p) const
{
    double e = normal.unit().dot(p);
    if (noiseAmplitude > 0) {
        noise::Fbm f;
        f.frequency = noiseFrequency;
        f.octaves = 3;
        e += noiseAmplitude / f.amplitudeSum() *
             noise::fbm3(noiseSeed, f, float(p[0]), float(p[1]), float(p[2]));
    }
    return e;
}

int Strata::tileAt(const Vec3d& p) const
{
    const double e = elevation(p);
    size_t k = 0;
    while (k < tops.size() && e >= tops[k]) ++k;
    return tiles[k];
}

void PlacementRules::restrictTo(const BBoxd& roi)
{
    for (int a = 0; a < 3; ++a) {
        require(std::isfinite(roi.min()[a]) && std::isfinite(roi.max()[a]) &&
                    roi.min()[a] < roi.max()[a],
                "amplify", "roi", "finite with min < max on every axis",
                std::to_string(roi.min()[a]) + ".." + std::to_string(roi.max()[a]));
    }
    region = BBoxd(maxComponent(region.min(), roi.min()), minComponent(region.max(), roi.max()));
}

double PlacementRules::reach() const
{
    return std::max(1.0, std::max(std::abs(distanceMin), std::abs(distanceMax)) + 0.5);
}

FieldPtr heightfieldTerrain(std::shared_ptr<const Heightfield> hf, double baseDepth,
                            PlacementRules& rules)
{
    HeightfieldSettings hs;
    hs.baseDepth = baseDepth;
    hs.exactDistance = rules.reach();
    FieldPtr ground = heightfieldField(hf, hs);
    hs.closed = false;
    rules.surface = heightfieldField(hf, hs);
    rules.region = BBoxd(Vec3d(1.0, 1.0, -1e30), Vec3d(hf->width() - 1.0, hf->depth() - 1.0, 1e30));
    return ground;
}

FieldPtr levelSetTerrain(openvdb::FloatGrid::ConstPtr grid, const PlacementRules& rules,
                         double maxMemoryBytes)
{
    return levelSetField(std::move(grid), rules.reach(), maxMemoryBytes);
}

void checkTileSizes(const std::vector<std::shared_ptr<const BlockTile>>& tiles, bool mixedSizes)
{
    for (const auto& t : tiles) {
        if (!mixedSizes && t->size() != tiles.front()->size()) {
            fail<ValueError>("amplify: tile sizes differ (", tiles.front()->size(), " m and ",
                             t->size(), " m); allow it explicitly (--mixed-tile-sizes / "
                             "mixed_tile_sizes=True)");
        }
    }
}

Strata Strata::fromJson(const nlohmann::json& j, const std::vector<std::string>& names)
{
    using nlohmann::json;
    Strata st;
    try {
        if (!j.is_object()) fail<ValueError>("strata: expected an object with \"layers\"");
        requireKnownKeys(j, {"normal", "noise", "layers"}, "strata", "the object");
        if (j.contains("normal")) {
            const auto& n = j.at("normal");
            st.normal = Vec3d(n.at(0).get<double>(), n.at(1).get<double>(), n.at(2).get<double>());
            require(st.normal.length() > 1e-9, "strata", "normal", "non-zero", "0");
        }
        if (j.contains("noise")) {
            const auto& n = j.at("noise");
            requireKnownKeys(n, {"amplitude", "frequency", "seed"}, "strata", "noise");
            st.noiseAmplitude = n.value("amplitude", 0.0);
            st.noiseFrequency = n.value("frequency", 0.05);
            st.noiseSeed = n.value("seed", uint64_t(1));
            require(std::isfinite(st.noiseAmplitude) && st.noiseAmplitude >= 0, "strata",
                    "noise amplitude", ">= 0", st.noiseAmplitude);
            require(std::isfinite(st.noiseFrequency) && st.noiseFrequency > 0, "strata",
                    "noise frequency", "> 0", st.noiseFrequency);
        }
        const json& layers = j.at("layers");
        if (!layers.is_array() || layers.empty()) fail<ValueError>("strata: \"layers\" must be a non-empty array");
        for (size_t k = 0; k < layers.size(); ++k) {
            const json& L = layers[k];
            // The last layer reaches up: it has no top.
            requireKnownKeys(L, k + 1 < layers.size() ? std::vector<std::string>{"tile", "top"}
                                                      : std::vector<std::string>{"tile"},
                             "strata", "layers[" + std::to_string(k) + "]" + (k + 1 < layers.size() ? "" : " (the top one)"));
            const json& t = L.at("tile");
            int index = -1;
            if (t.is_number_integer()) {
                index = t.get<int>();
            } else {
                const std::string name = t.get<std::string>();
                for (size_t i = 0; i < names.size(); ++i) if (names[i] == name) index = int(i);
                if (index < 0) {
                    std::string known;
                    for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
                    fail<ValueError>("strata: layer ", k, " names unknown tile '", name,
                                     "' (tiles: ", known, ")");
                }
            }
            if (index < 0 || index >= int(names.size())) {
                fail<ValueError>("strata: layer ", k, " tile index ", index, " out of range");
            }
            st.tiles.push_back(index);
            if (k + 1 < layers.size()) {
                const double top = L.at("top").get<double>();
                if (!st.tops.empty() && !(top > st.tops.back())) {
                    fail<ValueError>("strata: layer tops must increase (layer ", k, ")");
                }
                st.tops.push_back(top);
            }
        }
    } catch (const nlohmann::json::exception& e) {
        fail<ValueError>("strata: malformed (", e.what(), ")");
    }
    return st;
}

std::shared_ptr<const blocks::Presence> computePresence(const Field& terrain,
                                                        const BlockTile& tile,
                                                        const PlacementRules& rules,
                                                        AmplifyStats& stats,
                                                        const Strata* strata, int tileIndex,
                                                        Task* task,
                                                        const std::function<bool(int, int, int)>& only)
{
    rules.validate();
    const auto t0 = std::chrono::steady_clock::now();
    const double s = tile.size();
    const BBoxd tb = terrain.bounds();
    const Field& ground = rules.surface ? *rules.surface : terrain;
    if (!isBounded(tb)) fail<ValueError>("amplify: the terrain must be bounded");
    // Anchors lie inside their block's home box; a copy can qualify only if an anchor is
    // within [va, vb] of the surface, hence inside the terrain's box widened by max(|va|, |vb|).
    Vec3d alo(1e30), ahi(-1e30);
    for (const auto& b : tile.blocks) {
        for (const auto& a : b.anchors) {
            alo = minComponent(alo, Vec3d(a[0], a[1], a[2]));
            ahi = maxComponent(ahi, Vec3d(a[0], a[1], a[2]));
        }
    }
    const double widen = std::max(std::abs(rules.distanceMin), std::abs(rules.distanceMax));
    std::vector<Cell> cells;
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = int(std::floor((tb.min()[a] - widen - ahi[a]) / s));
        hi[a] = int(std::floor((tb.max()[a] + widen - alo[a]) / s));
    }
    // Counted before any is made: a terrain hundreds of km wide over a 10 m tile would ask
    // for trillions of cells (and their int indices would overflow).
    double count = 1;
    for (int a = 0; a < 3; ++a) {
        // ... and inside the rules' region (the --roi) when it is smaller.
        const double bmin = std::max(tb.min()[a] - widen, rules.region.min()[a]);
        const double bmax = std::min(tb.max()[a] + widen, rules.region.max()[a]);
        const double l = std::floor((bmin - ahi[a]) / s);
        const double h = std::floor((bmax - alo[a]) / s);
        count *= std::max(0.0, h - l + 1.0);
        lo[a] = int(std::max(l, -2e9));
        hi[a] = int(std::min(h, 2e9));
    }
    if (count * double(tile.blocks.size()) > 5e7) {
        fail<ValueError>("amplify: the terrain (", tb.extents()[0], " x ", tb.extents()[1], " x ",
                         tb.extents()[2], " m) spans ", count, " cells of the ", s, " m tile with ",
                         tile.blocks.size(), " blocks each, over the presence table's 5e7; "
                         "amplify a region of it (--roi) or use a larger tile");
    }
    auto grid = std::make_shared<PresenceGrid>();
    for (int a = 0; a < 3; ++a) {
        grid->lo[a] = lo[a];
        grid->dim[a] = std::max(0, hi[a] - lo[a] + 1);
    }
    grid->sparse = bool(only);
    for (int i = lo[0]; i <= hi[0]; ++i)
        for (int j = lo[1]; j <= hi[1]; ++j)
            for (int k = lo[2]; k <= hi[2]; ++k) {
                if (only) {
                    if (!only(i, j, k)) continue;
                    grid->slots.push_back(grid->slot(i, j, k));
                }
                cells.push_back({i, j, k});
            }

    const size_t nb = tile.blocks.size();
    grid->blocks = nb;
    grid->flags.assign(cells.size() * nb, 0); // cells run x, y, z like slot() (or row)
    uint8_t* flags = grid->flags.data();
    const double h = 0.05; // central-difference step for the terrain gradient (m)
    Task quiet;
    parallelFor(task ? *task : quiet, cells.size(), 1, [&](size_t c) {
        const Vec3d shift = Vec3d(cells[c].ix, cells[c].iy, cells[c].iz) * s;
        for (size_t b = 0; b < nb; ++b) {
            const auto& anchors = tile.blocks[b].anchors;
            const size_t n = std::min<size_t>(size_t(rules.anchors), anchors.size());
            size_t pass = 0;
            for (size_t k = 0; k < n; ++k) {
                const Vec3d w = Vec3d(anchors[k][0], anchors[k][1], anchors[k][2]) + shift;
                if (!rules.region.isInside(w)) continue;
                if (rules.mask) {
                    // Nearest pixel centre; outside the image counts as masked out.
                    const long i = std::lround(w[0] / rules.maskCellSize);
                    const long j = std::lround(w[1] / rules.maskCellSize);
                    if (i < 0 || j < 0 || i >= rules.mask->width || j >= rules.mask->height) continue;
                    if (rules.mask->at(int(i), int(j)) < 0.5f) continue;
                }
                if (strata && strata->tileAt(w) != tileIndex) continue;
                const double d = ground.eval(w);
                if (d < rules.distanceMin || d > rules.distanceMax) continue;
                const Vec3d g(ground.eval(w + Vec3d(h, 0, 0)) - ground.eval(w - Vec3d(h, 0, 0)),
                              ground.eval(w + Vec3d(0, h, 0)) - ground.eval(w - Vec3d(0, h, 0)),
                              ground.eval(w + Vec3d(0, 0, h)) - ground.eval(w - Vec3d(0, 0, h)));
                const double len = g.length();
                if (len <= 0) continue;
                if (std::abs(g[2] / len) < rules.maxSlope) ++pass;
            }
            flags[c * nb + b] = double(pass) > rules.fraction * double(n) ? 1 : 0;
        }
    });
    const double amp = tile.params.relief.amplitude;
    for (size_t c = 0; c < cells.size(); ++c) {
        const Vec3d shift = Vec3d(cells[c].ix, cells[c].iy, cells[c].iz) * s;
        for (size_t b = 0; b < nb; ++b) {
            if (!flags[c * nb + b]) continue;
            ++stats.replicated;
            const auto& B = tile.blocks[b];
            const BBoxd bb(Vec3d(B.boundsMin[0], B.boundsMin[1], B.boundsMin[2]) + shift - Vec3d(amp),
                           Vec3d(B.boundsMax[0], B.boundsMax[1], B.boundsMax[2]) + shift + Vec3d(amp));
            if (!grid->any) { grid->box = bb; grid->any = true; } else grid->box.expand(bb);
        }
    }
    stats.cells += cells.size();
    stats.blockBytes += blocks::tileFieldBytes(tile);
    stats.presenceSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return grid;
}

namespace {

// A bake id (tile·kMaterialStride + block, or kNoId on terrain) as block index and material.
inline void splitId(float id, float& block, float& material)
{
    if (id < 0) {
        block = kNoId;
        material = kTerrainMaterial;
        return;
    }
    const float tile = std::floor(id / kMaterialStride);
    block = id - tile * kMaterialStride;
    material = tile + 1.0f;
}

} // namespace

openvdb::FloatGrid::Ptr splitMaterial(openvdb::FloatGrid& ids)
{
    auto material = ids.deepCopy();
    material->setName("material");
    for (auto it = ids.beginValueOn(); it; ++it) {
        float block, mat;
        splitId(it.getValue(), block, mat);
        it.setValue(block);
        material->tree().setValueOn(it.getCoord(), mat);
    }
    return material;
}

FieldPtr AmplifiedParts::united() const
{
    if (!blocks) return terrain;
    if (carveGap > 0) return std::make_shared<Carved>(terrain, blocks, float(carveGap));
    return csg(CsgOp::Union, {terrain, blocks});
}

FieldPtr amplifiedTerrain(FieldPtr terrain,
                          const std::vector<std::shared_ptr<const BlockTile>>& tiles,
                          const PlacementRules& rules, AmplifyStats& stats,
                          const Strata* strata, double carveGap, Task* task)
{
    return amplifiedParts(std::move(terrain), tiles, rules, stats, strata, carveGap, task).united();
}

// The aperiodic tiling's copies that qualify: the cubes whose blocks' anchors (within
// [-s/2, 3s/2) of the cube's corner, origin + s·(i, j, k)) can lie within the distance range
// of the surface, each with the presence of its colouring's tile over its own cubes.
FieldPtr aperiodicBlocks(const Field& terrain, std::shared_ptr<const blocks::AperiodicTiles> tiles,
                         const PlacementRules& rules, AmplifyStats& stats, Task* task)
{
    const double s = tiles->size();
    const BBoxd tb = terrain.bounds();
    if (!isBounded(tb)) fail<ValueError>("amplify: the terrain must be bounded");
    const Field& ground = rules.surface ? *rules.surface : terrain;
    const double widen = std::max(std::abs(rules.distanceMin), std::abs(rules.distanceMax));
    std::array<int, 3> lo, hi;
    double count = 1;
    for (int a = 0; a < 3; ++a) {
        const double bmin = std::max(tb.min()[a] - widen, rules.region.min()[a]);
        const double bmax = std::min(tb.max()[a] + widen, rules.region.max()[a]);
        const double u = tiles->origin()[a];
        const double l = std::floor((bmin - u - 1.5 * s) / s), h = std::floor((bmax - u + 0.5 * s) / s);
        count *= std::max(0.0, h - l + 1.0);
        lo[size_t(a)] = int(std::max(l, -2e9));
        hi[size_t(a)] = int(std::min(h, 2e9));
    }
    if (count > 5e6) {
        fail<ValueError>("amplify: the terrain (", tb.extents()[0], " x ", tb.extents()[1], " x ",
                         tb.extents()[2], " m) spans ", count, " cubes of the ", s,
                         " m aperiodic tiling, over 5e6; amplify a region of it (--roi) or use a larger tile");
    }
    if (count <= 0) return nullptr;
    // A cube whose anchors all stay farther from the surface than the distance range holds no
    // copy: |f| / L bounds the distance from below (L: the ground's Lipschitz constant).
    const double reach = std::sqrt(3.0) * s + widen;
    const double lip = std::max(1.0, ground.lipschitz());
    // Each cube's colouring, or -1 where no copy can qualify: decided once (a ground
    // evaluation per cube), then looked up by the field and by every colouring's presence.
    std::array<int, 3> dim;
    for (int a = 0; a < 3; ++a) dim[size_t(a)] = hi[size_t(a)] - lo[size_t(a)] + 1;
    std::vector<int32_t> keyOf(size_t(count), -1);
    const Vec3d u = tiles->origin();
    Task quiet;
    Task& t = task ? *task : quiet;
    parallelFor(t, keyOf.size(), 64, [&](size_t c) {
        const int k = int(c % size_t(dim[2])), j = int(c / size_t(dim[2]) % size_t(dim[1]));
        const int i = int(c / (size_t(dim[2]) * size_t(dim[1])));
        const Vec3d centre = (Vec3d(lo[0] + i, lo[1] + j, lo[2] + k) + Vec3d(0.5)) * s + u;
        if (std::abs(ground.eval(centre)) / lip <= reach) {
            keyOf[c] = tiles->cubeKey(lo[0] + i, lo[1] + j, lo[2] + k);
        }
    });
    auto key = [&](int i, int j, int k) {
        const int64_t x = int64_t(i) - lo[0], y = int64_t(j) - lo[1], z = int64_t(k) - lo[2];
        if (x < 0 || y < 0 || z < 0 || x >= dim[0] || y >= dim[1] || z >= dim[2]) return -1;
        return int(keyOf[size_t((x * dim[1] + y) * dim[2] + z)]);
    };
    return blocks::aperiodicField(
        tiles, lo, hi, t, [&](int i, int j, int k) { return key(i, j, k) >= 0; },
        [&](int k, const BlockTile& tile) {
            return computePresence(terrain, tile, rules, stats, nullptr, 0, task,
                                   [&, k](int i, int j, int l) { return key(i, j, l) == k; });
        });
}

AmplifiedParts amplifiedParts(FieldPtr terrain,
                              const std::vector<std::shared_ptr<const BlockTile>>& tiles,
                              const PlacementRules& rules, AmplifyStats& stats,
                              const Strata* strata, double carveGap, Task* task,
                              std::shared_ptr<const blocks::AperiodicTiles> aperiodic)
{
    if (!terrain) fail<ValueError>("amplify: the terrain is required");
    if (tiles.empty()) fail<ValueError>("amplify: at least one tile is required");
    if (tiles.size() > 255) fail<ValueError>("amplify: at most 255 tiles");
    std::vector<FieldPtr> parts{terrain};
    if (aperiodic) {
        if (strata || tiles.size() > 1) fail<ValueError>("amplify: aperiodic tiles take one tile and no strata");
        const size_t before = stats.replicated;
        FieldPtr blocks = aperiodicBlocks(*terrain, aperiodic, rules, stats, task);
        if (blocks && stats.replicated > before) parts.push_back(std::move(blocks));
    }
    for (size_t i = 0; i < tiles.size() && !aperiodic; ++i) {
        if (!tiles[i]) fail<ValueError>("amplify: tile ", i, " is null");
        if (!strata && i > 0) break; // without strata only the first tile is used
        const size_t before = stats.replicated;
        blocks::TileFieldOptions o;
        o.presence = computePresence(*terrain, *tiles[i], rules, stats, strata, int(i), task);
        o.idOffset = float(i) * kMaterialStride;
        o.cullPerOctant = true;
        if (stats.replicated > before) parts.push_back(blocks::tileField(tiles[i], o));
    }
    if (carveGap > 0) {
        require(std::isfinite(carveGap) && carveGap < 10, "amplify", "carve gap", "in (0, 10) m",
                carveGap);
    }
    AmplifiedParts out;
    out.terrain = terrain;
    out.carveGap = carveGap;
    if (parts.size() == 2) out.blocks = parts[1];
    if (parts.size() > 2) out.blocks = csg(CsgOp::Union, std::vector<FieldPtr>(parts.begin() + 1, parts.end()));
    return out;
}

namespace {

using LeafOrigins = std::vector<openvdb::Coord>;

// Leaves of @a a that @a b has not (sorted, as the tree visits them).
LeafOrigins leavesMissingIn(const openvdb::FloatTree& a, const openvdb::FloatTree& b)
{
    LeafOrigins out;
    openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(b);
    for (auto leaf = a.cbeginLeaf(); leaf; ++leaf) {
        if (!acc.probeConstLeaf(leaf->origin())) out.push_back(leaf->origin());
    }
    std::sort(out.begin(), out.end());
    return out;
}

// Sign (±1) of @a field over each leaf of @a origins, read at the leaf's centre: where a
// part has no leaf its values are beyond the band, one sign over the leaf (a distance
// cannot change sign between two voxels without a value within a voxel of zero). The
// grid's own tiles cannot be asked: their signs come from a flood fill, which a chunk's
// clip leaves open at the chunk's faces. One point per batch, of radius 0 and the band's
// hint, so that every operand that stays beyond the band there is skipped unevaluated.
std::vector<float> signsAt(const Field& field, const LeafOrigins& origins, double dx, float band)
{
    std::vector<float> sign(origins.size(), 1.0f);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, origins.size(), 256),
                      [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k != r.end(); ++k) {
            const float x = float((origins[k].x() + 3.5) * dx), y = float((origins[k].y() + 3.5) * dx),
                        z = float((origins[k].z() + 3.5) * dx);
            Batch b{&x, &y, &z, 1, Vec3f(x, y, z), 0.0f, band, band};
            float v = 0;
            field.evalBatch(b, &v);
            sign[k] = v < 0 ? -1.0f : 1.0f;
        }
    });
    return sign;
}

// The sign found for leaf @a origin, or 0 when the leaf is not in @a origins.
float signOf(const LeafOrigins& origins, const std::vector<float>& signs, const openvdb::Coord& origin)
{
    const auto it = std::lower_bound(origins.begin(), origins.end(), origin);
    return it != origins.end() && *it == origin ? signs[size_t(it - origins.begin())] : 0.0f;
}

} // namespace

AmplifyResult uniteWithBlocks(openvdb::FloatGrid::Ptr terrain, const openvdb::FloatGrid& blocks,
                              const openvdb::FloatGrid& blockIds, const Field& terrainField,
                              const Field& blocksField)
{
    using openvdb::FloatGrid;
    using LeafT = openvdb::FloatTree::LeafNodeType;
    const float bg = terrain->background();
    const double dx = terrain->voxelSize()[0];
    // Where one part has no leaf, its sign over the other's leaf, from its field.
    const LeafOrigins terrainOnly = leavesMissingIn(terrain->tree(), blocks.tree());
    const LeafOrigins blocksOnly = leavesMissingIn(blocks.tree(), terrain->tree());
    const std::vector<float> blockSign = signsAt(blocksField, terrainOnly, dx, bg);
    const std::vector<float> terrainSign = signsAt(terrainField, blocksOnly, dx, bg);
    FloatGrid::Ptr surface = terrain;
    // Leaves where either has band voxels; new ones take the terrain's (sign-carrying) tiles.
    surface->tree().topologyUnion(blocks.tree());
    // The id grids: the surface's topology (OpenVDB's parallel topology copy).
    auto ids = emptyAttribute(blockIds.getName(), surface->transform().copy(), kNoId);
    ids->setTree(std::make_shared<openvdb::FloatTree>(surface->tree(), kNoId, kNoId,
                                                      openvdb::TopologyCopy()));
    auto material = emptyAttribute("material", surface->transform().copy(), kNoId);
    material->setTree(std::make_shared<openvdb::FloatTree>(surface->tree(), kNoId, kNoId,
                                                           openvdb::TopologyCopy()));
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(surface->tree());
    openvdb::tree::LeafManager<openvdb::FloatTree> idLeaves(ids->tree());
    openvdb::tree::LeafManager<openvdb::FloatTree> materialLeaves(material->tree());
    // The three trees have one topology: their leaves come in the same order.
    if (idLeaves.leafCount() != leaves.leafCount() || materialLeaves.leafCount() != leaves.leafCount()) {
        fail<ValueError>("amplify: internal error: united topologies differ");
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves.leafCount(), 64),
                      [&](const tbb::blocked_range<size_t>& range) {
        auto bacc = blocks.getConstAccessor();
        auto iacc = blockIds.getConstAccessor();
        for (size_t k = range.begin(); k != range.end(); ++k) {
            LeafT& leaf = leaves.leaf(k);
            LeafT& idLeaf = idLeaves.leaf(k);
            LeafT& matLeaf = materialLeaves.leaf(k);
            const openvdb::Coord origin = leaf.origin();
            const LeafT* bl = bacc.probeConstLeaf(origin);
            const LeafT* il = iacc.probeConstLeaf(origin);
            const float btile = bl ? 0.0f : bg * signOf(terrainOnly, blockSign, origin);
            float* f = leaf.buffer().data();
            if (const float ts = signOf(blocksOnly, terrainSign, origin)) {
                std::fill(f, f + LeafT::SIZE, ts * bg);
            }
            float* id = idLeaf.buffer().data();
            float* mat = matLeaf.buffer().data();
            const float* t = bl ? bl->buffer().data() : nullptr;
            const float* ti = il ? il->buffer().data() : nullptr;
            for (openvdb::Index n = 0; n < LeafT::SIZE; ++n) {
                const float tv = t ? t[n] : btile;
                const float u = std::min(f[n], tv);
                const bool on = std::abs(u) < bg;
                // The block's id where the block is closer: tile·kMaterialStride + block.
                const float raw = on && tv < f[n] && ti ? ti[n] : kNoId;
                f[n] = on ? u : (u < 0 ? -bg : bg);
                splitId(raw, id[n], mat[n]);
                if (!on) mat[n] = kNoId;
                leaf.setActiveState(n, on);
            }
            idLeaf.setValueMask(leaf.getValueMask());
            matLeaf.setValueMask(leaf.getValueMask());
        }
    });
    // Leaves left without band voxels become tiles of their sign; the leaves' own inactive
    // values already carry it, so the fill only classifies the tiles above them.
    openvdb::tools::pruneLevelSet(surface->tree());
    openvdb::tools::signedFloodFill(surface->tree(), true, 1, /*minLevel=*/1);
    openvdb::tools::pruneInactiveWithValue(ids->tree(), kNoId);
    openvdb::tools::pruneInactiveWithValue(material->tree(), kNoId);
    return {surface, ids, material};
}

AmplifyResult bakeAmplified(const AmplifiedParts& parts, BakeSettings settings,
                            AmplifyStats& stats, openvdb::util::NullInterrupter* interrupt)
{
    settings.withAttribute = true;
    settings.attributeName = "block_id";
    const auto t0 = std::chrono::steady_clock::now();
    const FieldPtr united = parts.united();
    BakeResult r;
    if (!parts.blocks || parts.carveGap > 0 || planRequested()) {
        r = bake(*united, settings, interrupt);
    } else {
        // The box (or chunk) and memory check of the single bake of f̃; both parts fill it.
        const BakeEstimate e = checkedEstimate(*united, settings);
        BakeSettings part = settings;
        part.chunk = ChunkSpec();
        if (!e.empty) part.region = regionOfBox(e.indexBox, settings.voxelSize);
        part.withAttribute = false;
        BakeResult f = bake(*parts.terrain, part, interrupt);
        part.withAttribute = true;
        const BakeResult t = bake(*parts.blocks, part, interrupt);
        const auto t1 = std::chrono::steady_clock::now();
        AmplifyResult out = uniteWithBlocks(f.surface, *t.surface, *t.attribute, *parts.terrain,
                                            *parts.blocks);
        out.surface->setName(settings.gridName);
        stats.bake = t.stats;
        stats.bake.candidateLeaves += f.stats.candidateLeaves;
        stats.bake.fieldEvaluations += f.stats.fieldEvaluations;
        stats.bake.cullSeconds += f.stats.cullSeconds;
        stats.bake.fillSeconds += f.stats.fillSeconds;
        stats.bake.finishSeconds += f.stats.finishSeconds;
        stats.bake.leaves = out.surface->tree().leafCount();
        stats.bake.activeVoxels = size_t(out.surface->activeVoxelCount());
        stats.bakeSeconds += std::chrono::duration<double>(t1 - t0).count();
        stats.splitSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
        return out;
    }
    const auto t1 = std::chrono::steady_clock::now();
    AmplifyResult out{r.surface, r.attribute, splitMaterial(*r.attribute)};
    const auto t2 = std::chrono::steady_clock::now();
    stats.bake = r.stats;
    stats.bakeSeconds += std::chrono::duration<double>(t1 - t0).count();
    stats.splitSeconds += std::chrono::duration<double>(t2 - t1).count();
    return out;
}

std::vector<std::string> describe(const AmplifyStats& stats)
{
    char line[3][256];
    std::snprintf(line[0], sizeof line[0], "#R %zu replicated blocks (%zu cells examined); block "
                  "fields %.2f MB", stats.replicated, stats.cells, stats.blockBytes / 1e6);
    std::snprintf(line[1], sizeof line[1], "bake: %zu active voxels in %zu leaves",
                  stats.bake.activeVoxels, stats.bake.leaves);
    std::snprintf(line[2], sizeof line[2], "phases: presence %.3f s, bake %.3f s (cull %.3f, fill "
                  "%.3f, finish %.3f), split %.3f s", stats.presenceSeconds, stats.bakeSeconds,
                  stats.bake.cullSeconds, stats.bake.fillSeconds, stats.bake.finishSeconds,
                  stats.splitSeconds);
    return {line[0], line[1], line[2]};
}

} // namespace amplify
} // namespace rockvdb
