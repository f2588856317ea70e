// SPDX-License-Identifier: Apache-2.0
// rockvdb — aperiodic block tiles on corner-coloured cubes (implicit-blocks-rocky-scenery.txt
// §6.4: "Aperiodic tiling using Wang cubes or Corner Cubes would reduce visible artifacts";
// the corner cubes of aperiodic-rock-piles.txt §2–§3, as ops/rockpile/RockTiles.h builds them).
//
// Lattice vertices take one of K colours (2 to 4; a hash of their position and the seed); a
// cube is one of the K⁸ corner colourings. Space splits into the cores of lattice features,
// in tile sizes and by priority: a vertex core (the box of half-size 0.04 around it), an edge
// core (within 0.03 of the edge), a face core (within 0.02 of the face) and the cube's core
// (the rest of the cube). Every feature's blocks are a pure function of its vertices' colours
// (for K = 2: 2 vertex, 12 edge, 48 face and 256 cube regions, as Table 1 of the rock piles
// counts them), made in order of dimension:
//   1. its own Poisson points in its zone, away from the blocks of its sub-features (all
//      known to it: their colours are among its own). The zone: its core, and where it is
//      within a reach of 0.35 of it in the core of a feature that contains it, if it is the
//      nearest such feature of its dimension nested in the nearer lower ones (chainAt): two
//      features that may both place points somewhere always contain one another;
//   2. its own fracture discs (the type's density; the set directions are the tile set's);
//   3. the tile's phases on them (graph, cuts, clusters, visibility, fill: buildTile);
//   4. it keeps the blocks whose clusters have a point in its core — complete blocks that
//      reach into the zones of the features containing it, which fill around them (the
//      boundary between regions is made of blocks, not planes) — each kept a fracture width
//      off a sub-feature's block by a plane between them (one of its faces or a separating
//      plane), when one keeps all the block's points.
// A block straddling a tile face is the block of a vertex, edge or face region, the same in
// both cubes (one block of the world, owned by the cube at its feature's lower vertex). The
// lattice's origin is random (from the seed): a wall or floor at a round coordinate does not
// lie on lattice planes, where only the regions that recur most (1/K, 1/K², 1/K⁴) show.
//
// Departures and limits (docs/blocks.md has the measures): fractures do not continue from
// one region into another (each has its own discs); where a block reaches round a
// sub-feature's block, or grows into the zone of a feature it does not know, the two
// overlap and merge into one rock (no void, no fracture there: 24 % of the rock of seed 3's
// polyhedral 10 m set lies in two blocks); a region recurs with its colours, so block ids
// still match at tile-period shifts a few per cent of the time (K = 2), against none at other
// shifts (K = 3, 4 lower it, at the cost of making each cube's tile anew).
#pragma once

#include <rockvdb/blocks/BlockTile.h>

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

namespace rockvdb {
namespace blocks {

/// The colours of the lattice vertices: the table rows' default and range (addAperiodicRows)
/// and the constructor's check.
constexpr int kDefaultColours = 2, kMinColours = 2, kMaxColours = 4;

class AperiodicTiles
{
public:
    /// @brief The tile set of @a params (resolved and checked here). User fractures and
    /// authored blocks are tile coordinates of one periodic tile: refused (ValueError).
    explicit AperiodicTiles(const BlockTileParams& params, int colours = kDefaultColours);

    const BlockTileParams& params() const { return mParams; }
    double size() const { return mParams.tileSize; }

    /// The lattice's origin, a random point of [0, s)³ from the seed: cube (i, j, k) spans
    /// origin + s·[i, i + 1) × … (a wall or a floor at a round coordinate would otherwise lie
    /// on lattice planes, where only vertex, edge and face regions show, which recur most).
    Vec3d origin() const;
    /// Colours of the lattice vertices (2 to 4; K^8 cube colourings).
    int colours() const { return mColours; }
    int cubeKeys() const { int n = 1; for (int i = 0; i < 8; ++i) n *= mColours; return n; }
    /// Colour (0 to K - 1) of lattice vertex (i, j, k).
    int colour(int i, int j, int k) const;
    /// The cube at (i, j, k) (its lower corner, in tiles): digit dx + 2dy + 4dz (base K) is the
    /// colour of its corner (i + dx, j + dy, k + dz).
    int cubeKey(int i, int j, int k) const;

    /// @brief The blocks owned by a cube of colouring @a key — its lower vertex's, its three
    /// lower edges', its three lower faces' and its own — as for cube (0, 0, 0) (its lower
    /// corner at origin()), lower vertex first. Made on first use with the regions it needs.
    std::shared_ptr<const BlockTile> cubeTile(int key, Task& task) const;
    std::shared_ptr<const BlockTile> cubeTile(int key) const;

    /// @brief The ids of a cube tile's blocks (made with it): the cube's 8 regions take slots
    /// of 8192 ids (lower vertex, edges x, y, z, faces normal to x, y, z, the cube's own),
    /// each region its blocks' run at an offset hashed from its colours. Ids name content: a
    /// region's blocks have the same ids wherever it recurs, and different regions of a slot
    /// rarely share one (what a repetition measure needs; under kMaterialStride).
    std::shared_ptr<const std::vector<float>> cubeIds(int key, Task& task) const;

    /// @brief Make the cube tiles of @a keys: each level of regions (vertices, edges, faces,
    /// cubes) in parallel, so the result does not depend on the order of requests.
    void prepare(const std::vector<int>& keys, Task& task) const;

    /// Regions made so far (vertex, edge, face, cube), and their blocks.
    std::array<size_t, 4> regionsMade() const;

    /// A region: the blocks of one feature (spanning-axes mask: 0 vertex, 1/2/4 edge along
    /// x/y/z, 6/5/3 face normal to x/y/z, 7 cube) with the colours of its vertices (bit n =
    /// colour of its n-th vertex, vertices in the order of their offsets' bits), in its
    /// frame (its lower vertex at the origin).
    struct Region
    {
        std::vector<Block> blocks;
        size_t points = 0;  ///< Poisson points in its zone
        size_t dropped = 0; ///< clusters left to the features that contain it
    };
    const Region& region(int mask, int colours, Task& task) const;

private:
    using Key = std::pair<int, int>; // (mask, colours)
    void make(const Key& key, Task& task) const;

    BlockTileParams mParams;
    int mColours = 2;
    mutable std::mutex mMutex;
    mutable std::map<Key, std::shared_ptr<const Region>> mRegions;
    mutable std::map<int, std::shared_ptr<const BlockTile>> mCubes;
    mutable std::map<int, std::shared_ptr<const std::vector<float>>> mCubeIds;
};

/// Which copies of a cube tile exist: a Presence over the cubes of that colouring (its copies
/// elsewhere must be absent), for the colouring @a key and its tile.
using KeyPresenceFn = std::function<std::shared_ptr<const Presence>(int key, const BlockTile& tile)>;

/// @brief The aperiodic tiling over cubes [lo, hi] (inclusive, in tiles) as a Field: each cube
/// holds the cube tile of its colouring; ids are indices into the cube's tile (so a block's id
/// names the same content wherever it recurs). Other cubes are empty, and so are those
/// @a cubes (optional) leaves out; with @a presence (optional), only the copies it keeps.
/// Only the colourings of the cubes kept are made.
FieldPtr aperiodicField(std::shared_ptr<const AperiodicTiles> tiles, const std::array<int, 3>& lo,
                        const std::array<int, 3>& hi, Task& task,
                        const std::function<bool(int, int, int)>& cubes = {},
                        const KeyPresenceFn& presence = {});

} // namespace blocks
} // namespace rockvdb
