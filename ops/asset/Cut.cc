// SPDX-License-Identifier: Apache-2.0
#include "Cut.h"

#include <rockvdb/core/Error.h>

#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/Prune.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace rockvdb {
namespace asset {

namespace {

using Unregistered = openvdb::tree::ValueAccessor<const openvdb::FloatTree, false>;

} // namespace

bool asId(float v, int& id)
{
    if (!(v >= 0.0f) || v >= 16777216.0f || v != std::floor(v)) return false;
    id = int(v);
    return true;
}

std::map<int, openvdb::CoordBBox> surfaceIdBoxes(const openvdb::FloatGrid& surface,
                                                 const openvdb::FloatGrid& ids)
{
    const float bg = surface.background();
    Unregistered acc(surface.tree());
    std::map<int, openvdb::CoordBBox> boxes;
    for (auto it = ids.cbeginValueOn(); it; ++it) {
        int id;
        if (!asId(*it, id)) continue;
        // a tile of ids counts whole (rare: ids live in the band)
        if (it.isVoxelValue() && !(std::abs(acc.getValue(it.getCoord())) < bg)) continue;
        openvdb::CoordBBox b;
        it.getBoundingBox(b);
        boxes[id].expand(b);
    }
    return boxes;
}

std::vector<int> surfaceIdList(const openvdb::FloatGrid& surface, const openvdb::FloatGrid& ids)
{
    std::vector<int> out;
    for (const auto& [id, box] : surfaceIdBoxes(surface, ids)) out.push_back(id);
    return out;
}

CutResult cutId(const openvdb::FloatGrid& surface, const openvdb::FloatGrid& ids, int id,
                size_t maxVoxels, Task& task, const openvdb::CoordBBox* known)
{
    if (surface.transform() != ids.transform()) {
        fail<ValueError>("asset: the id grid '", ids.getName(), "' and the level set '",
                         surface.getName(), "' have different transforms");
    }
    const float bg = surface.background();
    const double h = surface.voxelSize()[0];

    // The block's band voxels give its box.
    openvdb::CoordBBox box;
    if (known) {
        box = *known;
    } else {
        const auto boxes = surfaceIdBoxes(surface, ids);
        const auto found = boxes.find(id);
        if (found != boxes.end()) box = found->second;
    }
    if (box.empty()) {
        const std::vector<int> all = surfaceIdList(surface, ids);
        if (all.empty()) {
            fail<ValueError>("asset: id ", id, " is not in '", ids.getName(), "' (it holds no ids)");
        }
        fail<ValueError>("asset: id ", id, " is not in '", ids.getName(), "' (it holds ", all.size(),
                         " ids from ", all.front(), " to ", all.back(), ")");
    }
    box.expand(2);
    const openvdb::Coord lo = box.min(), dim = box.dim();
    const size_t nx = size_t(dim.x()), ny = size_t(dim.y()), nz = size_t(dim.z());
    const size_t n = nx * ny * nz;
    if (n > maxVoxels) {
        fail<ValueError>("asset: id ", id, " spans ", dim.x(), " x ", dim.y(), " x ", dim.z(),
                         " voxels, more than the ", maxVoxels, " a cut may search");
    }
    auto index = [&](size_t i, size_t j, size_t k) { return (i * ny + j) * nz + k; };

    // φ and the band's ids over the box (z fastest). owner: id >= 0, -1 outside (φ >= 0),
    // -2 inside and not reached (yet), -3 inside and cut off at the box's faces.
    std::vector<float> phi(n);
    std::vector<int> owner(n);
    parallelFor(task, nx, 1, [&](size_t i) {
        Unregistered sacc(surface.tree()), iacc(ids.tree());
        for (size_t j = 0; j < ny; ++j) {
            for (size_t k = 0; k < nz; ++k) {
                const openvdb::Coord c = lo + openvdb::Coord(int(i), int(j), int(k));
                const size_t x = index(i, j, k);
                phi[x] = sacc.getValue(c);
                int v;
                if (!(phi[x] < 0.0f)) owner[x] = -1;
                else owner[x] = iacc.isValueOn(c) && asId(iacc.getValue(c), v) ? v : -2;
            }
        }
    });

    // Ownership spread inwards, breadth first from every band voxel in scan order.
    std::vector<size_t> queue;
    queue.reserve(n / 4);
    for (size_t x = 0; x < n; ++x) {
        if (owner[x] >= 0) queue.push_back(x);
    }
    const ptrdiff_t step[6] = {ptrdiff_t(ny * nz), -ptrdiff_t(ny * nz), ptrdiff_t(nz), -ptrdiff_t(nz), 1, -1};
    for (size_t q = 0; q < queue.size(); ++q) {
        if ((q & 0xfffff) == 0) task.check();
        const size_t x = queue[q];
        const size_t i = x / (ny * nz), j = (x / nz) % ny, k = x % nz;
        const bool inside[6] = {i + 1 < nx, i > 0, j + 1 < ny, j > 0, k + 1 < nz, k > 0};
        for (int d = 0; d < 6; ++d) {
            if (!inside[d]) continue;
            const size_t y = size_t(ptrdiff_t(x) + step[d]);
            if (owner[y] != -2) continue;
            owner[y] = owner[x];
            queue.push_back(y);
        }
    }
    std::vector<size_t>().swap(queue);
    // The box holds the block's band with a margin, so its own inside reaches the box's faces
    // only through a fused neighbour: there it is cut at the face (as another block's).
    for (size_t i = 0; i < nx; ++i) {
        for (size_t j = 0; j < ny; ++j) {
            for (size_t k = 0; k < nz; ++k) {
                if (i && j && k && i + 1 < nx && j + 1 < ny && k + 1 < nz) continue;
                int& o = owner[index(i, j, k)];
                if (o == id) o = -3;
            }
        }
    }

    // The block's grid: its own voxels as they are, the outside as it is, other blocks' inside
    // pushed out; a cut face where the block's inside meets another's.
    CutResult r;
    r.voxels = n;
    auto out = openvdb::FloatGrid::create(bg);
    out->setTransform(surface.transform().copy());
    out->setGridClass(openvdb::GRID_LEVEL_SET);
    out->setName(surface.getName());
    {
        auto acc = out->getAccessor();
        const float half = float(0.5 * h);
        for (size_t i = 0; i < nx; ++i) {
            task.check();
            for (size_t j = 0; j < ny; ++j) {
                for (size_t k = 0; k < nz; ++k) {
                    const size_t x = index(i, j, k);
                    const openvdb::Coord c = lo + openvdb::Coord(int(i), int(j), int(k));
                    const bool mine = owner[x] == id;
                    if (owner[x] == -1) {
                        if (phi[x] < bg) acc.setValueOn(c, phi[x]);
                        continue;
                    }
                    if (!mine) {
                        r.rebuilt = true; // someone else's inside: dropped
                        continue;
                    }
                    // mine and inside: a cut face where a 6-neighbour is another block's inside
                    const bool nb[6] = {i + 1 < nx, i > 0, j + 1 < ny, j > 0, k + 1 < nz, k > 0};
                    bool cut = false;
                    for (int d = 0; d < 6; ++d) {
                        if (!nb[d]) continue;
                        const size_t y = size_t(ptrdiff_t(x) + step[d]);
                        if (owner[y] != -1 && owner[y] != id) {
                            cut = true;
                            const size_t yi = y / (ny * nz), yj = (y / nz) % ny, yk = y % nz;
                            acc.setValueOn(lo + openvdb::Coord(int(yi), int(yj), int(yk)), half);
                        }
                    }
                    if (cut) acc.setValueOn(c, std::max(phi[x], -half));
                    else if (phi[x] > -bg) acc.setValueOn(c, phi[x]);
                    else acc.setValueOff(c, -bg); // deep inside: negative, inactive
                }
            }
        }
    }
    // Every voxel's sign is known: the block's inside is written (deep voxels inactive at
    // -background), everything else is outside, as the background says. No signedFloodFill:
    // it would guess the sign of unallocated regions (dropped neighbours) from their scan
    // neighbours, and could turn them inside. Uniform leaves collapse back to tiles.
    openvdb::tools::pruneLevelSet(out->tree());
    if (r.rebuilt) {
        const float hw = float(bg / h);
        out = openvdb::tools::levelSetRebuild(*out, 0.0f, hw, hw, nullptr, task.interrupter());
        task.check();
        out->setName(surface.getName());
        out->setGridClass(openvdb::GRID_LEVEL_SET);
    }
    out->insertMeta(surface); // the input's provenance and metadata
    r.grid = out;
    return r;
}

} // namespace asset
} // namespace rockvdb
