// rockvdb — the fractal-rock stage's front door: its parameter table and entry point.
//
// vdb_fractal_rock and rockvdb.fractal_rock are thin wrappers over runRock: the table gives
// both their options, defaults and checks, and the entry point stamps the provenance, so the
// two interfaces write the same grids, and a file's rockvdb:params fed back as
// `vdb_fractal_rock --params` remakes it bit for bit.
#pragma once

#include <rockvdb/fractal/FractalRock.h>

#include <rockvdb/core/Image.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

namespace rockvdb {
namespace fractal {

/// The tool the entry points record as the generator of what they make.
constexpr const char* kToolName = "vdb_fractal_rock";

/// One rock: its shape, size, orientation and place, and how it is baked.
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
    double maxMemoryGB;  ///< refuse work estimated above this (0 = 75% of RAM)

    /// @brief The semi-axes (size / 2).
    Vec3d extent() const { return size * 0.5; }
};

/// @brief The table of FractalRockParams (vdb_fractal_rock, rockvdb.fractal_rock).
const Schema<FractalRockParams>& rockSchema();

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

/// @brief Build one rock (phases: mesh, level set, normal map), the grid stamped with
/// provenance (the table's JSON). @a withLevelSet false: the mesh (and map) only.
RockResult runRock(const FractalRockParams& params, bool withLevelSet, bool withNormalMap,
                   Task& task);

} // namespace fractal
} // namespace rockvdb
