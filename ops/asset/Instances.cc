// SPDX-License-Identifier: Apache-2.0
#include "Instances.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/rockpile/RockPile.h>
#include <rockvdb/rockpile/RockPileStage.h>
#include <rockvdb/rockpile/RockTiles.h>

#include <openvdb/points/PointDataGrid.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace rockvdb {
namespace asset {

namespace {

using openvdb::points::PointDataGrid;

PointDataGrid::Ptr findPoints(const openvdb::GridPtrVec& grids, const std::string& path)
{
    PointDataGrid::Ptr only;
    size_t count = 0;
    for (const auto& g : grids) {
        auto p = openvdb::gridPtrCast<PointDataGrid>(g);
        if (!p) continue;
        if (p->getName() == "rocks") return p;
        only = p;
        ++count;
    }
    if (count == 1) return only;
    fail<ValueError>("asset: '", path, "' has ", count == 0 ? "no points grid" : "several points grids and none named 'rocks'",
                     " (write one with vdb_rockpile pile --points)");
}

} // namespace

PileInstances readPileInstances(const std::string& pointsPath, const std::string& tilesPath,
                                double halfWidth, Task& task)
{
    const auto grids = readGrids(pointsPath);
    const PointDataGrid::Ptr points = findPoints(*grids, pointsPath);
    const std::string rockType = openvdb::typeNameAsString<int32_t>();
    std::vector<PilePoint> list;
    for (auto leaf = points->tree().cbeginLeaf(); leaf; ++leaf) {
        task.check();
        const auto& desc = leaf->attributeSet().descriptor();
        const size_t ri = desc.find("rock");
        if (ri == openvdb::points::AttributeSet::INVALID_POS || desc.type(ri).first != rockType) {
            fail<ValueError>("asset: the points of '", pointsPath, "' have no int32 attribute 'rock' "
                             "(the library rock of each instance, as vdb_rockpile pile --points writes)");
        }
        openvdb::points::AttributeHandle<openvdb::Vec3f> pos(leaf->constAttributeArray("P"));
        openvdb::points::AttributeHandle<int32_t> rock(leaf->constAttributeArray(ri));
        for (auto it = leaf->beginIndexOn(); it; ++it) {
            list.push_back({rock.get(*it), points->transform().indexToWorld(
                                               it.getCoord().asVec3d() + openvdb::Vec3d(pos.get(*it)))});
        }
    }
    if (list.empty()) fail<ValueError>("asset: the points grid of '", pointsPath, "' holds no points");
    return pileInstances(rockpile::readTileSet(tilesPath), list, halfWidth,
                         "'" + pointsPath + "' (tile set '" + tilesPath + "')", task);
}

PileInstances pileInstances(const rockpile::TileSet& set, const std::vector<PilePoint>& points,
                            double halfWidth, const std::string& source, Task& task)
{
    if (points.empty()) fail<ValueError>("asset: ", source, " holds no points");
    const double dx = set.params.voxelSize();
    // Every point's rock and its shift in whole voxels: P = seedWorld(rock, shift).
    std::map<size_t, std::vector<openvdb::Coord>> shifts;
    for (const PilePoint& pt : points) {
        const openvdb::Vec3d& world = pt.position;
        const int64_t r = pt.rock;
        if (r < 0 || size_t(r) >= set.rocks.size() || set.rocks[size_t(r)].solidVoxels() == 0) {
            fail<ValueError>("asset: point at (", world.x(), ", ", world.y(), ", ", world.z(), ") of ",
                             source, " names rock ", r, ", not a rock of the tile set (", set.rocks.size(),
                             " rocks)");
        }
        const openvdb::Vec3d off =
            (world - rockpile::seedWorld(set, set.rocks[size_t(r)], openvdb::Coord(0))) / dx;
        const openvdb::Vec3d whole(std::round(off.x()), std::round(off.y()), std::round(off.z()));
        if (!((off - whole).length() <= 1e-3) || std::abs(whole.x()) > 1e9 || std::abs(whole.y()) > 1e9 ||
            std::abs(whole.z()) > 1e9) {
            fail<ValueError>("asset: point at (", world.x(), ", ", world.y(), ", ", world.z(), ") of ",
                             source, " is not where a copy of rock ", r, " can stand: the points and "
                             "the tile set do not belong together");
        }
        shifts[size_t(r)].push_back(openvdb::Coord(int(whole.x()), int(whole.y()), int(whole.z())));
    }

    PileInstances out;
    out.instances = points.size();
    out.voxelSize = dx;
    out.prototypes.reserve(shifts.size());
    for (auto& [rock, list] : shifts) {
        task.check();
        std::sort(list.begin(), list.end());
        Prototype p;
        p.rock = rock;
        const rockpile::Rock& r = set.rocks[rock];
        p.grid = rockpile::rockLevelSet(r, dx, openvdb::Coord(0), halfWidth);
        p.pivot = rockpile::seedWorld(set, r, openvdb::Coord(0));
        for (const openvdb::Coord& s : list) p.seeds.push_back(rockpile::seedWorld(set, r, s));
        out.prototypes.push_back(std::move(p));
    }
    return out;
}

} // namespace asset
} // namespace rockvdb
