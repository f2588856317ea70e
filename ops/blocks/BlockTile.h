// SPDX-License-Identifier: Apache-2.0
// rockvdb — fractured block tiles (implicit-blocks-rocky-scenery.txt §4).
//
// A cubic tile of side s is sampled with Poisson-sphere points (periodic), the points are
// linked into a neighbour graph, fracture discs D(c, r, n) cut the graph's edges, and the
// connected clusters G_i — split further until no disc separates two of their points — become
// the blocks B_i: the smooth intersection of the planes of each cluster's convex hull,
// warped by the gradient-based triplanar relief of §4.2, b_i(p) = c_i(ω⁻¹(p)).
// With fill (BlockTileParams::fill, the default) each hull is grown to its fractures before that:
// neighbouring clusters share one separating plane (the fracture disc's own plane where it
// separates them), and each block takes its side of it w/2 away, so neighbours meet across
// gaps of width w and never overlap (see Fill.cc); without, the paper's hull-only
// reading.
//
// This header is the stage's public face: the tile description (what the tile file stores),
// its generation, its file I/O, and the tile Field. vdb_amplify consumes tiles through it.
#pragma once

#include <rockvdb/core/Field.h>
#include <rockvdb/core/Task.h>
#include <rockvdb/relief/Relief.h>

#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace rockvdb {
namespace blocks {

/// Geomorphological block types (§4.1, Fig. 2).
enum class BlockType { Equidimensional, Prismatic, Polyhedral, Rhombohedral, Tabular, Columnar };

BlockType blockTypeFromString(const std::string& name);
const char* blockTypeName(BlockType type);

/// A fracture disc D(c, r, n) in tile coordinates; it cuts across the tile's faces too.
struct Disc
{
    Vec3d center;
    Vec3d normal; ///< unit
    double radius = 0;
};

/// A user-authored block (tile coordinates): a convex polytope, planes n·p <= d (n need not
/// be unit; boxes become these), or any bounded expression of the JSON expression language
/// (core/Expression.h: a sphere, a smooth union ...) as its compact JSON text. An expression
/// block keeps every later block (authored blocks after it, then the fractured ones)
/// fracture-width away from it: they grow up to it and are carved by it (TileField.cc).
struct AuthoredBlock
{
    std::vector<std::array<double, 4>> planes; ///< a polytope (empty for an expression)
    std::string expression;                    ///< an expression block's JSON (else empty)
    FieldPtr field;                            ///< the expression's field (else null)

    bool isExpression() const { return !expression.empty(); }
};

using relief::ReliefParams;

/// Everything that defines a tile; 0 / negative values mean "the type's default". Defaults,
/// ranges and help live in one table, tileSchema() (BlocksStage.h); a default-constructed
/// BlockTileParams holds the table's defaults.
struct BlockTileParams
{
    BlockTileParams();

    BlockType type;
    double tileSize;          ///< s, metres
    double pointRadius;       ///< Poisson radius of the points (default 0.034·s)
    double neighbourRadius;   ///< graph edge length limit (default 2·pointRadius)
    int discCount;            ///< number of generated fracture discs (-1: default)
    double discSpacing;       ///< Poisson radius of the disc centres
    double discRadiusMin, discRadiusMax;
    double jitterDeg;         ///< random tilt of the set normals
    double irregularFraction; ///< share of discs with a uniformly random normal
    Vec3d axis;               ///< dominant axis (bedding normal, column axis)
    double obliqueDeg;        ///< rhombohedral: angle between the three set normals
    std::vector<Disc> extraDiscs;  ///< user fractures
    std::vector<AuthoredBlock> authored;
    int minPoints;            ///< smaller clusters join a neighbour (fill) or are dropped
    double smoothRadius;      ///< R of the smooth intersection of the hull planes
    /// Blocks fill their tile up to the fractures (the gap between two neighbours is
    /// fractureWidth; clusters under minPoints join a neighbour). false: the paper's
    /// hull-only reading (each block is its points' hull, neighbours stand about a point
    /// spacing apart, clusters under minPoints are dropped; half the tile stays empty).
    bool fill;
    double fractureWidth;     ///< w (m) of the gaps between blocks (default 0.002·s)
    ReliefParams relief;      ///< the warp (the table's warp-* rows)
    uint64_t seed;

    /// @brief Fill in the type's defaults (documented in BlockTileParams.cc).
    void resolveDefaults();
    /// @brief ValueError naming the parameter unless usable (call after resolveDefaults).
    void validate() const;
    /// @brief The table's JSON (the tile file's "params"; CLI names).
    nlohmann::json toJson() const;
    /// @brief From the table's JSON; also reads the '_'-spelt, nested-relief form of tile
    /// files written before the table. @throw ValueError naming the key for unknown keys or
    /// bad values.
    static BlockTileParams fromJson(const nlohmann::json& j);
};

/// @brief User fractures from JSON: [{"center": [x,y,z], "normal": [x,y,z], "radius": r}].
std::vector<Disc> fracturesFromJson(const nlohmann::json& j);
/// @brief Authored blocks from JSON: [{"type": "box", "center", "size", "rotate"} or
/// {"type": "polytope", "planes": [[nx, ny, nz, d], ...]} (convex: boxes become polytopes),
/// or any other expression node ({"type": "sphere", ...}, {"type": "union", "smooth": R,
/// ...}; {"type": "expression", "expression": {...}} wraps a box or polytope node as an
/// expression)]. @throw ValueError naming the entry.
std::vector<AuthoredBlock> authoredListFromJson(const nlohmann::json& j);

/// @brief An authored expression block's field from its JSON text, checked: bounded, a
/// distance bound of slope 1 (no warp node: the tile's warp-* rows
/// roughen every block), no terrain node. @a what names the block in errors.
/// @throw ValueError naming it.
FieldPtr authoredExpressionField(const std::string& text, const std::string& what);

enum class BlockKind { Polytope, Segment, Point, Expression };

/// One block in its home frame (unwrapped tile coordinates; its anchor centroid lies in
/// [0, s)³). Floats: the tile file stores exactly these values.
struct Block
{
    BlockKind kind = BlockKind::Polytope;
    std::vector<std::array<float, 4>> planes; ///< outward unit n, d: h(p) = n·p - d, fold order
    std::array<float, 3> a{}, b{};            ///< segment ends / point centre
    float radius = 0;                         ///< segment / point radius
    std::string expression;                   ///< expression block: its JSON text
    std::array<float, 3> origin{};            ///< expression block: f(p - origin) (home frame)
    std::vector<std::array<float, 3>> vertices; ///< hull vertices (in memory only)
    std::vector<std::array<float, 3>> cluster;  ///< the cluster's points (in memory only)
    std::vector<float> areas;                   ///< facet area per plane (in memory only)
    std::vector<std::array<float, 3>> anchors;  ///< presence anchors, centroid first
    std::array<float, 3> boundsMin{}, boundsMax{}; ///< unwarped bounds
    int points = 0;        ///< cluster size
    bool authored = false; ///< from BlockTileParams::authored
};

struct BlockTileStats
{
    size_t points = 0, edges = 0, cutEdges = 0, discs = 0, blocks = 0;
    size_t droppedClusters = 0, droppedPoints = 0, visibilitySplits = 0, wrapCuts = 0;
    size_t mergedClusters = 0; ///< with fill: small clusters joined to a neighbour
    size_t smallBlocks = 0;    ///< with fill: small clusters no neighbour could take (blocks)
    double meanPoints = 0;
    double sampling = 0, graph = 0, fracturing = 0, clustering = 0, hulls = 0;
    double generation = 0; ///< sampling through hulls, seconds
    nlohmann::json toJson() const;
};

struct BlockTile
{
    BlockTileParams params;
    std::vector<Disc> discs; ///< every disc used, user discs last
    std::vector<Block> blocks;
    BlockTileStats stats;

    double size() const { return params.tileSize; }
};

/// @brief Generate a tile (§4.1–4.2): sampling, graph, fractures, clusters, hulls; the task
/// is checked between phases and per round of growing (a cancel throws Interrupted).
BlockTile generateTile(const BlockTileParams& params, Task& task);
BlockTile generateTile(const BlockTileParams& params);

/// @brief The tile file: JSON "rockvdb-tile" version 1 (parameters, discs, blocks, stats).
nlohmann::json tileToJson(const BlockTile& tile);
/// @brief A tile from its JSON, every value checked before anything is sized from it.
/// @throw IoError "corrupt <what>: <root>.blocks[12].planes has ... entries" (one line).
BlockTile tileFromJson(const nlohmann::json& j, const std::string& what = "tile file",
                       const std::string& root = "");
void writeTile(const BlockTile& tile, const std::string& path);
/// @throw IoError for unreadable files and corrupt content (naming the file and the key).
BlockTile readTile(const std::string& path);

/// @brief Which replicated copies exist (the presence function e_i of §5): copy
/// (ix, iy, iz) of block j is the block translated by s·(ix, iy, iz). Implementations
/// decide once per (cell, block), not per voxel.
class Presence
{
public:
    virtual ~Presence() = default;
    virtual bool present(int block, int ix, int iy, int iz) const = 0;
    /// @brief World box holding every present copy (blocks' bounds included).
    virtual BBoxd bounds() const = 0;
};

/// @brief Which copies of the blocks a tile field holds.
struct TileFieldOptions
{
    bool periodic = false;                   ///< the infinite periodic tiling t(p)
    std::array<int, 3> periods = {1, 1, 1};  ///< else: blocks whose home tile index < periods
    std::shared_ptr<const Presence> presence; ///< when set: the present copies only (§5)
    float idOffset = 0.0f;                    ///< attribute id = block index + idOffset
    /// When set: attribute id = blockIds[block index] + idOffset (one per block).
    std::shared_ptr<const std::vector<float>> blockIds;
    /// Cull blocks and planes per octant of a large batch (a baker's padded leaf) instead of
    /// per batch: ~20% faster, the same values within the band; values beyond it (bounds)
    /// differ, so a renormalised bake's band-edge voxels may too. Amplify sets it; a tile's
    /// own bakes keep the per-batch culling their files were made with.
    bool cullPerOctant = false;
};

/// @brief The tile as a Field: the union of its (warped) blocks, each a complete convex
/// block; attribute ids are block indices. Evaluation visits only the blocks whose bounds
/// can reach a batch (a cell grid over the tile), so a point costs a few blocks.
FieldPtr tileField(std::shared_ptr<const BlockTile> tile, const TileFieldOptions& options);

/// @brief Memory the tile's block fields need (bytes): every block's planes, bounds and
/// anchors, and the relief's table (texel warp-scale/64 over the tile: most of it, 2.0 of
/// 2.05 MB for the bench's 10 m tile). What Table 2 of the paper counts; the cell grid a tile
/// field adds for culling is not included.
double tileFieldBytes(const BlockTile& tile);

/// @brief A single block's field (home frame), for tests and per-block meshes.
FieldPtr blockField(std::shared_ptr<const BlockTile> tile, size_t index);

} // namespace blocks
} // namespace rockvdb
