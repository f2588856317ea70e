// SPDX-License-Identifier: Apache-2.0
// rockvdb — fractal rocks scattered on a ground (fractal-rocks-midpoint-displacement §1: "inserted
// into an artificial landscape, spatially distributed by another fBm").
//
// Candidates are drawn one after another from the seed (a pure sequence: the same call places
// the same rocks at any thread count): a position uniform in the area, kept with probability
// density(x, y) = ((1 + fbm(x, y)) / 2)^contrast, a size and proportions jittered from the
// table's, and kept only when its footprint disc (the radius that bounds the rock whatever its
// displacements and orientation) meets no earlier rock's: no two rocks interpenetrate. Each
// placed rock is then built (in parallel) and lowered onto the ground until its lowest point
// relative to the ground under it is `embed` of its height below it.
#pragma once

#include <rockvdb/fractal/FractalRock.h>

#include <rockvdb/core/Heightfield.h>

#include <openvdb/openvdb.h>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rockvdb {
namespace fractal {

/// The ground rocks rest on: a height z = h(x, y) and the xy box it covers.
class Ground
{
public:
    virtual ~Ground() = default;
    virtual double height(double x, double y) const = 0;
    /// @brief xmin, ymin, xmax, ymax it covers (nullopt: everywhere, the plane).
    virtual std::optional<std::array<double, 4>> bounds() const { return std::nullopt; }
};

/// @brief The plane z = 0.
std::shared_ptr<const Ground> planeGround();
/// @brief A heightfield, triangulated as heightfieldField triangulates it (so rocks rest on the
/// terrain vdb_heightfield bakes).
std::shared_ptr<const Ground> heightfieldGround(std::shared_ptr<const Heightfield> hf);
/// @brief A level set's top surface: per column of its voxels, the highest zero crossing
/// (searched from above; columns without one are at the grid's lowest point).
std::shared_ptr<const Ground> levelSetGround(const openvdb::FloatGrid& grid);

/// One placed rock.
struct Placed
{
    Vec3d position;                 ///< centre (m)
    Vec3d extent;                   ///< semi-axes (m)
    std::array<Vec3d, 3> rotation;  ///< rows of R
    uint64_t seed = 0;              ///< its displacements' seed
    double radius = 0;              ///< footprint radius bound (m)
};

struct ScatterSettings
{
    int count = 0;
    std::array<double, 4> area{};  ///< xmin, ymin, xmax, ymax
    Vec3d size;                    ///< nominal extents (m)
    double sizeJitter = 0, aspectJitter = 0, tilt = 0;
    double densityScale = 1, densityContrast = 0;
    int densityOctaves = 1;
    double embed = 0;
    int attempts = 30;             ///< candidates per asked rock before giving up
    RockShape shape;               ///< its seed seeds everything
};

struct ScatterStats
{
    size_t asked = 0, placed = 0, candidates = 0, rejectedDensity = 0, rejectedOverlap = 0;
    double placeSeconds = 0, meshSeconds = 0, levelSetSeconds = 0;
};

/// @brief Where the rocks go (serial, cheap: no meshes yet).
std::vector<Placed> placeRocks(const ScatterSettings& s, ScatterStats& stats, Task& task);

/// @brief A bound of how far displacements move a point of the unit sphere (canonical units).
double displacementBound(const RockShape& shape);

} // namespace fractal
} // namespace rockvdb
