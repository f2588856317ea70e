// SPDX-License-Identifier: Apache-2.0
// rockvdb — fractal rocks from an icosahedron (fractal-rocks-midpoint-displacement.txt).
//
// A rock starts as the icosahedron on the unit sphere (§4, Fig. 5). Each level displaces the
// midpoint of every edge along the direction from the rock's centre (§2), by an amount that is
// a pure function of the edge's two endpoints and the rock's seed (Smith's deterministic
// midpoint displacement: a counter-based hash of the endpoints' keys instead of the paper's
// hash into a table), so the two faces sharing an edge always agree and the mesh never cracks,
// whatever the order or the thread count. The range of a level's displacements shrinks with
// the edge length ℓ as ℓ^H (fBm), with a Hurst-like H per edge between H_down (facing down)
// and H_up (facing up) (§4, Figs. 6–7).
//
// Methods (§3, §5, Fig. 8):
//  - Interpolating: subdivision damping with the quadratic through endpoint – displaced
//    midpoint – endpoint: 5 vertices per edge, mid-midpoints inside, 16 sub-triangles per face
//    per level (20 → 320 → 5 120 → 81 920 triangles).
//  - Approximating: the same with the approximating (Bézier) quadratic: the curve's midpoint is
//    (A + 2M + B)/4, the displaced midpoint is its control point.
//  - Midpoint: plain midpoint displacement, 4 sub-triangles per face per level.
// Both damping variants evaluate one quadratic triangle patch per face (its edges are the
// edge curves), so the 3 mid-midpoints of Fig. 8 lie on the same smooth patch.
//
// The mesh is built in the rock's canonical frame (unit-sphere scale), then mapped to the
// world: p = centre + R · (extent ∘ p̂) with R the rock's orientation. "Up" is world +z.
#pragma once

#include <rockvdb/core/Field.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/Task.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace rockvdb {
namespace fractal {

enum class Method { Interpolating, Approximating, Midpoint };

Method methodFromString(const std::string& name);
const char* methodName(Method method);

/// Everything that shapes one rock (its size and place come separately). The values here
/// are neutral (a smooth sphere-like rock); the stage's table (rockSchema) holds the defaults
/// users get.
struct RockShape
{
    int levels = 0;                    ///< subdivision levels
    Method method = Method::Interpolating;
    double roughness = 0.0;            ///< first level's displacement range / its edge length
    double hUp = 0.5;                  ///< H of edges facing up (rough tops: smaller H)
    double hDown = 0.5;                ///< H of edges facing down (smooth bottoms: larger H)
    double hBlend = 0.5;               ///< H goes from H_down to H_up over cos θ ∈ [−b, b]
    uint64_t seed = 0;
};

/// @brief Triangles of a rock after @a levels levels: 20·16^L (damping) or 20·4^L.
double triangleCount(int levels, Method method);
/// @brief Bytes a rock mesh of this many levels takes while it is built (estimate).
double meshBytes(int levels, Method method);

/// A rock's mesh with what the normal map and the UVs need: per triangle its base face
/// (0..19) and its corners' lattice coordinates (i, j) in that face (the face's corners are
/// (0, 0), (n, 0), (0, n) with n = lattice()), exact integers at any level.
struct RockMesh
{
    std::vector<Vec3d> points;                  ///< canonical frame (unit-sphere scale)
    std::vector<openvdb::Vec3I> triangles;      ///< outward (counter-clockwise)
    std::vector<uint8_t> baseFace;              ///< per triangle
    std::vector<std::array<uint32_t, 6>> corners; ///< per triangle: i0 j0 i1 j1 i2 j2
    uint32_t lattice = 1;                       ///< lattice steps per base edge
};

/// @brief The rock in its canonical frame; @a up is world +z seen from that frame (Rᵀ z
/// divided by the extents, normalised), which decides each edge's H. The task is checked
/// between levels. @throw ValueError for bad parameters.
RockMesh buildRock(const RockShape& shape, const Vec3d& extent, const std::array<Vec3d, 3>& rotation,
                   Task& task);

/// @brief A rock's orientation: a uniform yaw, then a tilt about a random horizontal axis with
/// the tilted up axis uniform over the spherical cap of @a tiltDeg (180: any rotation).
std::array<Vec3d, 3> randomOrientation(uint64_t seed, double tiltDeg);
/// @brief The rotation as a unit quaternion (x, y, z, w): Houdini's / Blender's "orient".
std::array<double, 4> quaternionOf(const std::array<Vec3d, 3>& rotation);

/// @brief World positions: centre + R · (extent ∘ p̂).
std::vector<Vec3d> toWorld(const RockMesh& rock, const Vec3d& extent,
                           const std::array<Vec3d, 3>& rotation, const Vec3d& centre);

/// @brief Area-weighted vertex normals of a triangle mesh (unit; the paper's averaged normals).
std::vector<Vec3d> vertexNormals(const std::vector<Vec3d>& points,
                                 const std::vector<openvdb::Vec3I>& triangles);

/// The UV layout of the normal map: the 20 base faces in 10 square cells, 5 across and 2
/// down (face 2k and 2k+1 share cell k: column k mod 5, row k div 5); face 2k is the cell's
/// lower-left half (its corners 0, 1, 2 at the cell's (0,0), (1,0), (0,1)), face 2k+1 the
/// upper-right half (corners at (1,1), (0,1), (1,0)); each half shrunk by @a gutter (in cell
/// units) towards its incentre. v = 0 is the image's bottom row (OBJ convention).
struct UvLayout
{
    double gutter = 0.01;
    /// @brief uv of the point with barycentric coordinates (1 − a − b, a, b) of base face f.
    openvdb::Vec2d uv(int face, double a, double b) const;
};

/// @brief The world mesh of a rock with vertex normals and (when @a withUvs) UVs in the
/// normal-map layout.
Mesh rockMesh(const RockMesh& rock, const std::vector<Vec3d>& world, bool withUvs,
              const UvLayout& layout = UvLayout());

} // namespace fractal
} // namespace rockvdb
