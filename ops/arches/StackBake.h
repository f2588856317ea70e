// SPDX-License-Identifier: Apache-2.0
// rockvdb — level sets of material stacks: the convolution surface of §3.3 ("Arches: a Framework
// for Modeling Complex Terrains"), baked as a true narrow-band level set.
//
// The convolution f = V_M / (4σ³) − 1 is C0 and not a distance (its slope near a flat surface
// is between 1/σ and √2/σ, and it is constant ±1 farther than σ from the material). It is baked
// by the shared baker on the leaves that can hold the band (found from the stacks' interval
// ends, not by culling: a field that saturates at ±σ cannot be culled), as −σ·f, and then
// redistanced from its zero crossing by OpenVDB's fast sweeping (tools::sdfToSdf) on the voxels
// within w + 1 of a sign change, so every output is a signed distance with |∇| ≈ 1 over the
// whole band. The sweeping is ~3/4 of the time (bench `arches`).
//
// Departure from §3.3 (the default, Kernel::Interpolate; issue 38): the box convolution is,
// per stack, the box average of −clamp(d, −σ, σ) with d the signed vertical distance to the
// stack's material boundary (exactly so where a stack has one boundary within σ of z). With
// σ = s/2 its xy weights are bilinear between the four nearest stacks, but the ±σ clamp is
// much narrower than the height step between neighbours on any steep wall (a 56° wall rises
// 0.7 m per 0.5 m cell against σ = 0.25 m): the field is then the bilinear blend of the stacks'
// inside/outside alone, and every wall not aligned with the grid is a staircase of cell-wide
// teeth. Interpolate keeps the xy weights and the per-stack value ρ − (skeleton within ρ of z),
// with ρ = min(R, max(σ, the feature size of the stacks under the square: half a layer's or a
// gap's thickness, growing with distance from it)); R is the reach (unset: 4 cells). Where
// the stacks under the square differ by less than ρ in height, the surface is the bilinear
// interpolation of their heights: exact for planar walls at any orientation. Near a thin
// feature ρ falls to σ, i.e. to the box: an overhang lip's edge stays at its cells' edge (a
// wide clamp would pull it back by up to half a cell), a tunnel's roof is its stacks' roof,
// and what is thinner than σ is smoothed away as the paper does (pockets of a warped wall).
// ρ jumps where a thinner feature's stack enters the square (the field is not C0 there; the
// redistancing starts from its zero crossing). Kernel::Box is §3.3 as written.
#pragma once

#include <optional>

#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

#include <utility>
#include <vector>

namespace rockvdb {
namespace arches {

/// How the level set is reconstructed from the stacks (see above).
enum class Kernel { Box, Interpolate };
/// Interpolate's reach R when the arches table's reach row is unset, in stack cells.
constexpr double kDefaultReachCells = 4.0;

struct SkeletonBake
{
    double sigma = 1.0;       ///< the kernel's half size σ (m; in xy only for Interpolate)
    Kernel kernel = Kernel::Box;
    double reach = 0;         ///< Interpolate: the vertical reach R (m, > 0)
    double voxelSize = 1.0;   ///< m
    double halfWidth = 3.0;   ///< voxels
    double maxMemoryBytes = 0; ///< 0: 75% of RAM
    /// Bake only the candidate leaves inside this box (index space; a chunk with its halo).
    std::optional<openvdb::CoordBBox> box;
};

/// @brief The convolution surface of @a skeleton as a narrow-band level set (unnamed; the
/// caller names it). Negative inside the material. @a stats, when given, receives the bake's.
openvdb::FloatGrid::Ptr bakeSkeleton(const Skeleton& skeleton, const SkeletonBake& settings,
                                     Task& task, BakeStats* stats = nullptr);

/// @brief 'material' (float ids, background −1) over the active voxels of @a surface: the
/// visible material, the layer just under the surface point nearest to each voxel — the
/// material among @a mask's with the most volume in the first of the cubes of half size
/// h = voxel/2, 1, 2 … voxels centred h under that point along the normal that is at least
/// half full (ties to the lower id); where none is within σ + |φ|, the most volume in the cube
/// of half size σ + |φ| round the voxel. A layer one voxel thick shows.
openvdb::FloatGrid::Ptr materialGrid(const Stacks& stacks, MaterialMask mask, double sigma,
                                     const openvdb::FloatGrid& surface, Task& task);
/// @brief The same from the skeletons of single materials already built (in id order).
openvdb::FloatGrid::Ptr materialGrid(const std::vector<std::pair<Material, const Skeleton*>>& parts,
                                     double sigma, const openvdb::FloatGrid& surface, Task& task);

/// @brief The convolution field as a Field (value −σ·f; for tests and benchmarks).
FieldPtr convolutionField(std::shared_ptr<const Skeleton> skeleton, double sigma);
/// @brief The interpolating reconstruction as a Field (Skeleton::interpolated).
FieldPtr interpolatedField(std::shared_ptr<const Skeleton> skeleton, double sigma, double reach);

} // namespace arches
} // namespace rockvdb
