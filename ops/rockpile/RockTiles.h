// SPDX-License-Identifier: Apache-2.0
// rockvdb — rock tiles: Voronoi rocks in contact, periodic or on aperiodic corner cubes
// (aperiodic-rock-piles.txt §2–§5; arches-material-stacks-terrain.txt §5).
//
// Space is tiled by cubes whose corners sit on the integer lattice. Each cube is a grid of n³
// cells holding 1..s seeds p_k; rock k is the discrete (anisotropic) Voronoi cell of p_k on a
// grid of m voxels per cell (n_G = m·n per cube), eroded everywhere but near its contacts.
//
// Aperiodic tiling (§2–§3): lattice vertices take one of 2 colours; a cube is one of the 2⁸ =
// 256 corner colourings. A cell's seeds are a pure function of the colours of the lattice
// feature that owns it — the vertex, edge, face or cube (in that order) whose region's
// 1-neighbourhood holds the cell — and of its position relative to that feature, never of
// where the cube is. A rock's shape depends on the seeds of the 27 cells around its own, all
// owned by its region's feature or by sub-features of it (§3's copying of neighbour-region
// seeds, made a rule): the rocks of a region are identical in every cube that has it, and a
// rock straddling a cube face is the same rock seen from either side.
//
// Unique rocks are counted per region as Table 1 does: 2 vertex regions (the 2×2×2 cells
// around a lattice vertex), 12 edge, 48 face and 256 centre regions.
//
// Periodic tiling (arches §5): one colour, Poisson-sphere seeds in the periodic cube, Voronoi
// cells of equal weight (g = 1: Euclidean with anisotropy 1,1,1 and no jitter; the frames and
// extents still apply when set) and a Gaussian erosion resistance around the contacts.
#pragma once

#include <rockvdb/core/Field.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json_fwd.hpp>
#include <openvdb/openvdb.h>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace rockvdb {
namespace rockpile {

enum class Tiling { Aperiodic, Periodic };

/// Everything that defines a tile set. Lengths in cells unless stated (a cell is
/// cubeSize / n metres). Defaults, ranges and help live in one table, tilesSchema()
/// (RockPileStage.cc); a default-constructed RockTileParams holds the table's defaults.
struct RockTileParams
{
    RockTileParams();

    Tiling tiling;
    int n;                  ///< cells per cube edge (aperiodic: >= 4)
    int seedsMin, seedsMax; ///< seeds per cell n_k in [min, max] (s = max)
    /// α, β, γ: relative extents of the ellipsoidal distance f_k along the seed's random
    /// frame (see Seed; 5, 5, 1 makes flat rocks); each drawn uniformly in
    /// [v·(1 − anisotropyJitter), v].
    std::array<double, 3> anisotropy;
    double anisotropyJitter;
    double gMax;            ///< g_k uniform in [1, gMax] (the paper uses up to 4)
    int voxelsPerCell;      ///< m: n_G = m·n voxels per cube edge (Table 1: 10)
    double cubeSize;        ///< metres
    double contactInner;    ///< a: no erosion within a of a contact (cells; at least one
                            ///< voxel, so contacts survive sampling)
    double contactOuter;    ///< b: full erosion beyond b (cells)
    int erosionSteps;       ///< spheroidal erosion iterations
    double erosionRate;     ///< ε per step at full exposure
    double poissonRadius;   ///< periodic: seed spacing (cells; 0 = 0.8)
    uint64_t seed;

    /// @brief tilesSchema().fromJson: unknown keys and bad values are ValueErrors.
    static RockTileParams fromJson(const nlohmann::json& j);
    nlohmann::json toJson() const;
    /// @throw ValueError naming the parameter ("rockpile: n must be ...").
    void validate() const;
    int colours() const { return tiling == Tiling::Periodic ? 1 : 2; }
    double voxelSize() const { return cubeSize / double(n * voxelsPerCell); }
};

/// A seed p_k: position in cell units (global lattice of cells), its frame and scalings.
///
/// §4 writes f_k = α((p − p_k)·x)² + …, yet calls α, β, γ "the relative size along the
/// frame axes" and shows α = β = 5, γ = 1 as flat rocks (Figure 13): with α multiplying the
/// square those would be needles (the cell reaches farthest where d_k grows slowest). We
/// follow the words and the figure: α, β, γ are the relative extents, f_k = ((p − p_k)·x/α)²
/// + ((p − p_k)·y/β)² + ((p − p_k)·z/γ)², so the level sets of f_k are ellipsoids with
/// semi-axes ∝ α, β, γ.
struct Seed
{
    Vec3d p;
    std::array<Vec3d, 3> frame; ///< x, y, z unit axes
    Vec3d scale;                ///< α, β, γ: relative extents along x, y, z
    Vec3d weight;               ///< 1/α², 1/β², 1/γ²: the coefficients of f_k
    double g = 1.0;
    uint64_t key = 0;           ///< unique within the tile set, stable (ties break by it)

    /// d_k(q) = f_k(q)/g_k.
    double distance(const Vec3d& q) const
    {
        const Vec3d d = q - p;
        const double a = d.dot(frame[0]), b = d.dot(frame[1]), c = d.dot(frame[2]);
        return (weight[0] * a * a + weight[1] * b * b + weight[2] * c * c) / g;
    }
};

/// Lattice vertex colours: colour(i, j, k) in [0, colours).
using Colouring = std::function<int(int, int, int)>;

/// The seeds of cell @a cell (global cell coordinates) under @a colouring.
std::vector<Seed> cellSeeds(const RockTileParams& p, const openvdb::Coord& cell,
                            const Colouring& colouring);

/// A contact point c_ij kept between two rocks (tile voxel units, global).
struct Contact
{
    Vec3d point;
    uint64_t other = 0; ///< the other rock's seed key (a key names rock content: equal
                        ///< keys recur wherever the same region does)
    Vec3d otherSeed;    ///< the other rock's seed, cell units (which copy it is)
};

/// One rock: its eroded erosion state ρ ∈ [0, 1] over a dense voxel box (the rock field is
/// r = 2ρ − 1, trilinear, surface at ρ = 1/2), in global tile voxels (voxel v covers cell
/// coordinates [v, v + 1)/m, centre at (v + ½)/m).
struct Rock
{
    Seed seed;
    openvdb::Coord origin;   ///< first voxel of the box
    openvdb::Coord dims;     ///< box size
    std::vector<float> rho;  ///< x-major: ((x·dims.y) + y)·dims.z + z
    std::vector<Contact> contacts;
    size_t voronoiVoxels = 0; ///< voxels of the discrete Voronoi cell before erosion

    float at(const openvdb::Coord& v) const;
    size_t solidVoxels() const; ///< voxels with ρ > 1/2
};

/// @brief Rock k of cell @a cell: the discrete Voronoi cell of seed @a index among the seeds
/// of the 27 cells around it, its contacts and @a p.erosionSteps steps of spheroidal erosion.
Rock makeRock(const RockTileParams& p, const openvdb::Coord& cell, int index,
              const Colouring& colouring);

/// The regions of a tile set: 2 vertex, 12 edge, 48 face, 256 centre (aperiodic), or the one
/// periodic cube.
struct Region
{
    int type = 0;                 ///< 3 vertex, 2 edge, 1 face, 0 centre (boundary axes)
    std::array<int, 3> axes{{0, 0, 0}}; ///< per axis: 1 if the region lies on a lattice plane
    std::vector<int> colours;     ///< of the feature's lattice vertices, canonical order
    std::vector<size_t> rocks;    ///< indices into TileSet::rocks
};

struct RockTileStats
{
    size_t stones = 0, regions = 0, seeds = 0, contacts = 0;
    double seedSeconds = 0, voronoiSeconds = 0, erosionSeconds = 0, levelSetSeconds = 0;
};

struct TileSet
{
    RockTileParams params;
    std::vector<Region> regions;
    std::vector<Rock> rocks;
    RockTileStats stats;
};

/// @brief Every unique rock of the tile set, in parallel (deterministic); @a task is stepped
/// per batch of rocks (a cancel throws Interrupted).
TileSet generateTiles(const RockTileParams& p, Task& task);
TileSet generateTiles(const RockTileParams& p);

/// @brief The rocks whose seeds lie in the cube at lattice position @a cube under
/// @a colouring (each computed from that cube's point of view).
std::vector<Rock> cubeRocks(const RockTileParams& p, const openvdb::Coord& cube,
                            const Colouring& colouring);

/// @brief A narrow-band level set of the rock surface (r = 0) in tile voxels shifted by
/// @a offset voxels: distances to the trilinear surface sampled where it crosses the grid's
/// edges (each crossing offered to the voxels round its edge, then the nearest carried
/// outward layer by layer), half width @a halfWidth voxels. Inside voxels all lie in leaves,
/// so the tree needs no sign flood fill.
openvdb::FloatGrid::Ptr rockLevelSet(const Rock& rock, double voxelSize,
                                     const openvdb::Coord& offset = openvdb::Coord(0),
                                     double halfWidth = 3.0);

/// @brief The tile set as one grid for its file: `rho`, a fog volume (saved as half floats)
/// holding every rock's erosion state ρ in its own atlas slot (rock i's canonical voxel v at
/// v + offset_i), with metadata `rockvdb:tiles` (JSON format 1: params, stats, the regions
/// with their rocks, and per rock its key, seed, atlas offset, box, solid and Voronoi voxels
/// and contact count). The paper's rock field r = 2ρ − 1 is all a pile needs.
openvdb::FloatGrid::Ptr tileGrid(const TileSet& set, Task& task);
openvdb::FloatGrid::Ptr tileGrid(const TileSet& set);

/// @brief The tile set back from a grid written by tileGrid, every value of its metadata
/// checked before anything is sized from it: each rock's box inside the grid's voxels.
/// @a file names it in errors (else the grid's name).
/// @throw ValueError when the grid holds no tile set; IoError "corrupt rock tile set 'f':
/// rockvdb:tiles.rocks[3].dims[0] has value ..." for a wrong value.
TileSet tilesFromGrid(const openvdb::FloatGrid& rho, const std::string& file = "");

/// @brief Every rock's narrow-band level set in its own atlas slot of one level set
/// `library` (metadata `rockvdb:library_offsets`: the slot offsets, rock order), built in
/// parallel; @a seconds (optional) receives the time taken; @a ids (optional) the grid
/// `rock_id` (class unknown, background −1): the library rock's index on each of its voxels,
/// the piece attribute a DCC copies by (points' `variant`).
openvdb::FloatGrid::Ptr libraryGrid(const TileSet& set, Task& task, double halfWidth = 3.0,
                                    double* seconds = nullptr, openvdb::FloatGrid::Ptr* ids = nullptr);
openvdb::FloatGrid::Ptr libraryGrid(const TileSet& set, double halfWidth = 3.0,
                                    double* seconds = nullptr, openvdb::FloatGrid::Ptr* ids = nullptr);

/// @brief Where each rock's seed sits in the library (world, m; rock order): the pivot that
/// copies library rock i onto an instance, x ↦ P + (x − pivot_i).
std::vector<Vec3d> librarySeeds(const TileSet& set, double halfWidth = 3.0);

/// @brief A rock's level-set leaves shifted by @a offset voxels (what rockLevelSet holds;
/// the caller owns them). Piles assemble these.
std::vector<openvdb::FloatTree::LeafNodeType*> rockLeavesShifted(
    const Rock& rock, double voxelSize, const openvdb::Coord& offset, double halfWidth);

/// @brief The voxels of the leaves rockLeavesShifted may return (whole leaves; empty for a
/// rock without voxels).
openvdb::CoordBBox rockLeafBounds(const Rock& rock, const openvdb::Coord& offset, double halfWidth);

} // namespace rockpile
} // namespace rockvdb
