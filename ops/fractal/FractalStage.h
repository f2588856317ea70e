// SPDX-License-Identifier: Apache-2.0
// rockvdb — the fractal-rock stage's front door: its parameter table and entry point.
//
// vdb_fractal_rock and rockvdb.fractal_rock are thin wrappers over runFractal: the table gives
// both their options, defaults and checks, and the entry point stamps the provenance, so the
// two interfaces write the same grids, and a file's rockvdb:params fed back as
// `vdb_fractal_rock --params` remakes it bit for bit.
#pragma once

#include <rockvdb/fractal/FractalRock.h>
#include <rockvdb/fractal/Scatter.h>

#include <rockvdb/core/Image.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <optional>
#include <string>
#include <vector>

namespace rockvdb {
namespace fractal {

/// The tool the entry points record as the generator of what they make.
constexpr const char* kToolName = "vdb_fractal_rock";

/// One rock (count = 0) or a scatter of count rocks on a ground: the shape, size, orientation
/// and place, and how it is baked. One table for both, so the CLI and Python's fractal_rock and
/// fractal_scatter share every name; a row of the other mode left at its default.
struct FractalRockParams
{
    FractalRockParams();

    RockShape shape;
    Vec3d size;          ///< the base icosahedron's extents along x, y, z before rotation (m)
    double tilt;         ///< orientation: random yaw, then a tilt up to this (degrees; 180: any)
    Vec3d center;        ///< the rock's centre (m)
    double voxelSize;    ///< m
    double halfWidth;    ///< voxels
    int normalLevels;    ///< the normal map's model: this many levels finer (§7)
    int normalMapSize;   ///< pixels per cell of the normal map (the image is 5·n × 2·n)
    std::string normalSpace; ///< the normal map's space: "object" or "tangent"
    double maxMemoryGB;  ///< refuse work estimated above this (0 = 75% of RAM)

    // Scatter (count > 0).
    int count;                              ///< rocks asked for (0: one rock at center)
    std::optional<std::array<double, 4>> area; ///< xmin, ymin, xmax, ymax (unset: the ground's)
    double sizeJitter, aspectJitter;
    double densityScale, densityContrast;
    int densityOctaves;
    double embed;                           ///< share of a rock's height below the ground
    int attempts;                           ///< candidates per asked rock
    double groundCellSize, groundHeightScale; ///< a heightfield image ground
    std::string groundGrid;                 ///< a .vdb ground's level set (empty: 'surface' or the only one)
    int material;                           ///< >= 0: also a 'material' grid with this id

    // Carve (§9: a chain of count rocks subtracted from a solid).
    std::optional<std::array<double, 3>> carveStart; ///< unset: the solid's centre
    Vec3d carveDirection;
    double carveWander;

    /// @brief The semi-axes (size / 2).
    Vec3d extent() const { return size * 0.5; }
};

/// @brief The table of FractalRockParams (vdb_fractal_rock, rockvdb.fractal_rock and
/// rockvdb.fractal_scatter).
const Schema<FractalRockParams>& rockSchema();

/// Rows that only a scatter reads, and rows that only a single rock reads.
const std::vector<std::string>& scatterRows();
const std::vector<std::string>& singleRockRows();
const std::vector<std::string>& carveRows();
/// The scatter rows about the ground and placement (a carve's chain reads none of them).
const std::vector<std::string>& groundRows();

struct RockStats
{
    size_t triangles = 0, vertices = 0, activeVoxels = 0;
    double meshSeconds = 0, levelSetSeconds = 0, normalMapSeconds = 0;
    double volume = 0;  ///< of the mesh (m³)
};

struct RockResult
{
    RockMesh rock;               ///< canonical frame
    Mesh mesh;                   ///< world: normals, and UVs (normal-map layout) when asked
    openvdb::FloatGrid::Ptr surface; ///< level set 'surface'
    std::vector<float> normalMap;    ///< RGB, rows from the top, when asked (see normalMapHelp)
    int normalMapWidth = 0, normalMapHeight = 0;
    RockStats stats;
};

/// @brief What the normal map holds and where (the --help text).
const char* normalMapHelp();

/// @brief Write a normal map (RGB float EXR, n/2 + 1/2, rows from the top) made in @a space
/// ("object" or "tangent") for a mesh file written with @a up: an object-space map is turned
/// as that mesh is (Blender's OBJ importer keeps a y-up file's frame as the object's own).
/// The header's string attribute `rockvdb:normal_space` names the space ("object, z up",
/// "object, y up" or "tangent"); `rockvdb:normal_encoding` the encoding.
void writeNormalMap(const std::string& path, int width, int height, std::vector<float> rgb,
                    const std::string& space, UpAxis up);

/// @brief Build one rock (phases: mesh, level set, normal map); a step of runFractal, which
/// stamps the provenance. @a withLevelSet false: the mesh (and map) only.
RockResult runRock(const FractalRockParams& params, bool withLevelSet, bool withNormalMap,
                   Task& task);

struct ScatterResult
{
    std::vector<Placed> rocks;
    openvdb::FloatGrid::Ptr surface;   ///< level set 'surface': the union of the rocks
    openvdb::FloatGrid::Ptr rockId;    ///< 'rock_id': the index of the nearest rock (float ids)
    openvdb::FloatGrid::Ptr material;  ///< 'material' (params.material on every voxel), or null
    openvdb::GridBase::Ptr points;     ///< VDB points 'rocks' (P, orient, pscale, rock), when asked
    Mesh mesh;                         ///< every rock's mesh, triangle groups = rock index
    ScatterStats stats;
};

/// @brief The ground of a scatter: a heightfield image (.exr / .png, with the table's ground
/// cell size and height scale), a level set .vdb (its ground-grid), or the plane z = 0 (empty
/// path). @throw IoError / ValueError naming the file.
std::shared_ptr<const Ground> loadGround(const std::string& path, const FractalRockParams& params);

/// @brief Scatter count rocks on @a ground (phases: place, meshes, level set); a step of
/// runFractal, which stamps the provenance.
ScatterResult runScatter(const FractalRockParams& params, const Ground& ground, bool points,
                         bool withMesh, Task& task);

struct CarveResult
{
    std::vector<Placed> rocks;       ///< the chain
    openvdb::FloatGrid::Ptr surface; ///< the solid minus the chain (the solid's name)
    openvdb::FloatGrid::Ptr cave;    ///< the chain's union, level set 'cave'
};

/// @brief Cave creation (§9, "subtract concatenated rocks out of a quadric volume"): a random
/// walk of count rocks (full random orientations, neighbours overlapping) from carve-start
/// along carve-direction, united and subtracted from @a solid (tools::csgDifferenceCopy), on
/// the solid's voxels.
CarveResult runCarve(const FractalRockParams& params, const openvdb::FloatGrid& solid, Task& task);

/// The three things the stage makes.
enum class FractalMode
{
    Auto,    ///< chosen from the inputs: a carve solid -> Carve, count > 0 -> Scatter, else Rock
    Rock,    ///< one rock (count 0): vdb_fractal_rock, rockvdb.fractal_rock
    Scatter, ///< count rocks on a ground: --count N, rockvdb.fractal_scatter
    Carve,   ///< a cave: --carve SOLID --count N, rockvdb.fractal_carve
};

/// What runFractal works on besides the table's values.
struct FractalInputs
{
    FractalMode mode = FractalMode::Auto;
    /// Scatter ground: a path (a heightfield image or a level set .vdb, read by loadGround
    /// with the table's ground rows), or a level set grid; neither: the plane z = 0.
    std::string groundPath;
    openvdb::FloatGrid::ConstPtr groundGrid;
    /// Carve: the solid, a level set .vdb path or a grid.
    std::string carvePath;
    openvdb::FloatGrid::ConstPtr carveGrid;
    /// Provenance names of grids given in memory ({"ground": ...} / {"carve": ...}); paths
    /// name themselves.
    nlohmann::json source = nlohmann::json::object();
    bool levelSet = true;   ///< rock: bake its level set (false: the mesh only)
    bool normalMap = false; ///< rock: its normal map (§7)
    bool mesh = false;      ///< scatter: every rock's mesh (a rock's mesh is always made)
    bool points = false;    ///< scatter: the instances as VDB points
};

struct FractalResult : StageResult
{
    FractalMode mode = FractalMode::Rock;
    RockResult rock;       ///< mode Rock
    ScatterResult scatter; ///< mode Scatter
    CarveResult carve;     ///< mode Carve
    /// The mesh a --mesh file gets: the rock's, or every scattered rock's (groups = rock).
    const Mesh& mesh() const { return mode == FractalMode::Scatter ? scatter.mesh : rock.mesh; }
};

/// @brief The fractal-rock stage, vdb_fractal_rock and rockvdb.fractal_rock / fractal_scatter
/// / fractal_carve alike: choose the mode (FractalMode), refuse inputs the mode does not
/// read, load the ground or the solid, run it (runRock, runScatter or runCarve). grids: the
/// rock's 'surface'; the scatter's 'rock_id' ('material') and 'surface'; the carve's solid
/// and 'cave'. Stats: counts and times per mode, and the phases.
FractalResult runFractal(const FractalRockParams& params, const FractalInputs& inputs, Task& task);

} // namespace fractal
} // namespace rockvdb
