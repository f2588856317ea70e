// SPDX-License-Identifier: Apache-2.0
// rockvdb — rock piles: instancing a tile set's rocks into a support object
// (aperiodic-rock-piles.txt §6).
//
// Cubes sit with their corners on the integer lattice (scaled by the cube size); each lattice
// point takes a colour from a hash of (seed, point) — a stochastic aperiodic tiling. Every
// lattice vertex, edge, face and cube meeting the support holds its region's rocks; a rock is
// placed when more than a threshold fraction of its anchors (its voxel centres and its seed)
// lie inside the support, unless it lies deeper than twice the largest embedding radius.
#pragma once

#include <rockvdb/rockpile/RockTiles.h>

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Field.h>
#include <rockvdb/core/Mesh.h>

#include <openvdb/openvdb.h>

#include <cstdint>
#include <vector>

namespace rockvdb {
namespace rockpile {

/// How a support file is read.
struct SupportOptions
{
    std::string grid;        ///< level set in a .vdb ("" = 'surface', else the only level set)
    UpAxis up = UpAxis::Z;   ///< up axis of a mesh file (y: Blender's OBJ default, Houdini)
};

/// A pile's parameters. Defaults, ranges and help live in one table, pileSchema()
/// (RockPileStage.cc); a default-constructed PileParams holds the table's defaults.
struct PileParams
{
    PileParams();

    double threshold;        ///< fraction of anchors inside the support, in (0, 1]
    bool dropDeep;           ///< drop rocks deeper than 2 × the largest embedding radius
    uint64_t seed;           ///< lattice colours (and a JSON support's noise)
    double halfWidth = 3.0;  ///< of the output level set, voxels (the rocks' own band)
    /// Material id written on every rock voxel (grid 'material', for uniting the pile with
    /// other stages' material grids); −1 = no material grid.
    int material;
    SupportOptions support;  ///< how a support file is read
    /// One chunk of the pile's level sets (core/Chunks.h): the box of every placed rock's
    /// leaves, cut on leaf faces; rocks are selected over the whole support in every chunk.
    ChunkParams chunking;

    /// @throw ValueError naming the parameter.
    void validate() const;
};

/// One placed rock.
struct Instance
{
    size_t rock = 0;        ///< index into TileSet::rocks (the library rock)
    size_t region = 0;      ///< index into TileSet::regions (the tile)
    openvdb::Coord shift;   ///< voxels added to the rock's canonical voxels
    Vec3d position;         ///< its seed, world (m)
    double insideFraction = 0;
};

struct PileStats
{
    size_t features = 0, candidates = 0, placed = 0, droppedDeep = 0;
    double selectSeconds = 0, levelSetSeconds = 0;
};

struct Pile
{
    std::vector<Instance> instances;
    openvdb::FloatGrid::Ptr surface; ///< union of the placed rocks (level set)
    openvdb::FloatGrid::Ptr rockId;  ///< instance index per band voxel (class unknown, bg −1)
    openvdb::FloatGrid::Ptr material; ///< PileParams::material on rockId's voxels (or null)
    PileStats stats;
};

/// @brief World position of tile voxel @a v (voxel centres at v·dx: the lattice point i sits
/// at (i·n·m − ½)·dx).
Vec3d voxelToWorld(const TileSet& set, const Vec3d& v);

/// @brief World position of rock @a rock's seed when its canonical voxels are shifted by
/// @a shift voxels (what an instance's position and the points' P hold).
Vec3d seedWorld(const TileSet& set, const Rock& rock, const openvdb::Coord& shift);

/// @brief The largest embedding radius of the set's rocks (m): the farthest solid voxel
/// from its seed, plus a voxel.
double maxRockRadius(const TileSet& set);

/// @brief A level set as a support, its band widened (widenBand) to the depth the
/// deep-rock test reads: twice the largest rock radius and a little.
FieldPtr levelSetSupport(openvdb::FloatGrid::ConstPtr grid, const TileSet& set);


/// @brief A support from a file: a level set .vdb, a JSON expression of primitives (.json,
/// relative paths from its folder, @a seed for its noise) or a closed mesh (.obj, .stl,
/// .ply; converted by tools::meshToLevelSet at the tile voxel size or 1/256 of its extent).
/// @throw ValueError for other extensions or an open mesh.
FieldPtr loadSupport(const std::string& path, const TileSet& set, uint64_t seed = 0,
                     const SupportOptions& options = {});

/// @brief Choose the rocks of @a set that fill @a support (negative inside, metres).
std::vector<Instance> selectRocks(const TileSet& set, const Field& support, const PileParams& p,
                                  Task& task, PileStats* stats = nullptr);
std::vector<Instance> selectRocks(const TileSet& set, const Field& support, const PileParams& p,
                                  PileStats* stats = nullptr);

/// @brief The union level set of @a instances and its rock ids (in parallel).
Pile buildPile(const TileSet& set, std::vector<Instance> instances, const PileParams& p,
               Task& task);
Pile buildPile(const TileSet& set, std::vector<Instance> instances, const PileParams& p);

/// @brief The instances as a VDB points grid "rocks" for copying the library's rocks
/// (libraryGrid) in Houdini: P (the seed), orient (identity), pscale 1, variant = rock (the
/// library's `rock_id`), pivot (that rock's seed in the library), id, rock, tile = region.
openvdb::GridBase::Ptr instancePoints(const std::vector<Instance>& instances, const TileSet& set);

} // namespace rockpile
} // namespace rockvdb
