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

struct SkeletonBake
{
    double sigma = 1.0;       ///< the kernel's half size σ (m)
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
/// material among @a mask's with the most volume in the cube of half size σ + |φ| around each
/// voxel (the cube reaches the surface; ties to the lower id).
openvdb::FloatGrid::Ptr materialGrid(const Stacks& stacks, MaterialMask mask, double sigma,
                                     const openvdb::FloatGrid& surface, Task& task);
/// @brief The same from the skeletons of single materials already built (in id order).
openvdb::FloatGrid::Ptr materialGrid(const std::vector<std::pair<Material, const Skeleton*>>& parts,
                                     double sigma, const openvdb::FloatGrid& surface, Task& task);

/// @brief The convolution field as a Field (value −σ·f; for tests and benchmarks).
FieldPtr convolutionField(std::shared_ptr<const Skeleton> skeleton, double sigma);

} // namespace arches
} // namespace rockvdb
