#include "Amplify.h"

#include <core/Combinators.h>
#include <core/Error.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <map>
#include <tuple>
#include <vector>

namespace rockvdb {
namespace amplify {

using blocks::BlockTile;

namespace {

struct Cell
{
    int ix, iy, iz;
    bool operator<(const Cell& o) const { return std::tie(ix, iy, iz) < std::tie(o.ix, o.iy, o.iz); }
};

class PresenceGrid final : public blocks::Presence
{
public:
    std::map<Cell, std::vector<uint8_t>> cells; // present flag per block, per examined cell
    BBoxd box;
    bool any = false;

    bool present(int block, int ix, int iy, int iz) const override
    {
        auto it = cells.find(Cell{ix, iy, iz});
        return it != cells.end() && it->second[size_t(block)] != 0;
    }
    BBoxd bounds() const override { return any ? box : BBoxd(Vec3d(0), Vec3d(-1)); }
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
}

std::shared_ptr<const blocks::Presence> computePresence(const Field& terrain,
                                                        const BlockTile& tile,
                                                        const PlacementRules& rules,
                                                        AmplifyStats& stats)
{
    rules.validate();
    const auto t0 = std::chrono::steady_clock::now();
    const double s = tile.size();
    const BBoxd tb = terrain.bounds();
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
    for (int i = lo[0]; i <= hi[0]; ++i)
        for (int j = lo[1]; j <= hi[1]; ++j)
            for (int k = lo[2]; k <= hi[2]; ++k) cells.push_back({i, j, k});
    require(double(cells.size()) * double(tile.blocks.size()) <= 5e7, "amplify",
            "terrain size / tile size", "small enough for the presence table",
            std::to_string(cells.size()) + " cells");

    const size_t nb = tile.blocks.size();
    std::vector<std::vector<uint8_t>> flags(cells.size(), std::vector<uint8_t>(nb, 0));
    const double h = 0.05; // central-difference step for the terrain gradient (m)
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cells.size(), 1),
        [&](const tbb::blocked_range<size_t>& r) {
            for (size_t c = r.begin(); c != r.end(); ++c) {
                const Vec3d shift = Vec3d(cells[c].ix, cells[c].iy, cells[c].iz) * s;
                for (size_t b = 0; b < nb; ++b) {
                    const auto& anchors = tile.blocks[b].anchors;
                    const size_t n = std::min<size_t>(size_t(rules.anchors), anchors.size());
                    size_t pass = 0;
                    for (size_t k = 0; k < n; ++k) {
                        const Vec3d w = Vec3d(anchors[k][0], anchors[k][1], anchors[k][2]) + shift;
                        if (!rules.region.isInside(w)) continue;
                        const double d = terrain.eval(w);
                        if (d < rules.distanceMin || d > rules.distanceMax) continue;
                        const Vec3d g(terrain.eval(w + Vec3d(h, 0, 0)) - terrain.eval(w - Vec3d(h, 0, 0)),
                                      terrain.eval(w + Vec3d(0, h, 0)) - terrain.eval(w - Vec3d(0, h, 0)),
                                      terrain.eval(w + Vec3d(0, 0, h)) - terrain.eval(w - Vec3d(0, 0, h)));
                        const double len = g.length();
                        if (len <= 0) continue;
                        if (std::abs(g[2] / len) < rules.maxSlope) ++pass;
                    }
                    flags[c][b] = double(pass) > rules.fraction * double(n) ? 1 : 0;
                }
            }
        });
    auto grid = std::make_shared<PresenceGrid>();
    const double amp = tile.params.relief.amplitude;
    for (size_t c = 0; c < cells.size(); ++c) {
        bool any = false;
        const Vec3d shift = Vec3d(cells[c].ix, cells[c].iy, cells[c].iz) * s;
        for (size_t b = 0; b < nb; ++b) {
            if (!flags[c][b]) continue;
            any = true;
            ++stats.replicated;
            const auto& B = tile.blocks[b];
            const BBoxd bb(Vec3d(B.boundsMin[0], B.boundsMin[1], B.boundsMin[2]) + shift - Vec3d(amp),
                           Vec3d(B.boundsMax[0], B.boundsMax[1], B.boundsMax[2]) + shift + Vec3d(amp));
            if (!grid->any) { grid->box = bb; grid->any = true; } else grid->box.expand(bb);
        }
        if (any) grid->cells.emplace(cells[c], std::move(flags[c]));
    }
    stats.cells += cells.size();
    for (const auto& b : tile.blocks) {
        stats.blockBytes += double(b.planes.size() * sizeof(b.planes[0]) +
                                   b.anchors.size() * sizeof(b.anchors[0]) + 64);
    }
    stats.presenceSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return grid;
}

FieldPtr amplifiedTerrain(FieldPtr terrain, std::shared_ptr<const BlockTile> tile,
                          const PlacementRules& rules, AmplifyStats& stats)
{
    if (!terrain || !tile) fail<ValueError>("amplify: terrain and tile are required");
    blocks::TileFieldOptions o;
    o.presence = computePresence(*terrain, *tile, rules, stats);
    if (stats.replicated == 0) return terrain;
    return csg(CsgOp::Union, {terrain, blocks::tileField(tile, o)});
}

} // namespace amplify
} // namespace rockvdb
