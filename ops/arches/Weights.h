// SPDX-License-Identifier: Apache-2.0
// rockvdb — texture weights of material stacks ("Arches: a Framework for Modeling Complex
// Terrains", §6, Figure 21): "for every vertex p of the mesh, we evaluate the ratio of visible
// materials in a cubic box domain Ω centered at p ... by computing the visible surface of the
// material stacks intersecting Ω". Here every voxel of the ground's band gets, per ground
// material, the share of the stacks' exposed faces (tops, undersides and sides facing air or
// water) inside the cube that belongs to it: fog grids weight_sand, weight_bedrock,
// weight_rocks in [0, 1] that sum to 1 wherever the cube sees any exposed face, for DCC
// shaders to blend textures by.
#pragma once

#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

#include <vector>

namespace rockvdb {
namespace arches {

/// Exposed faces of the stacks by material, per stack, for area queries in a cube.
class ExposedFaces
{
public:
    explicit ExposedFaces(const Stacks& stacks);

    /// @brief The exposed area (m²) of each material (indexed by Material) inside the cube
    /// ‖q − p‖∞ < half.
    void areas(const Vec3d& p, double half, double out[kMaterialCount]) const;

private:
    StackGeometry mGeometry;
    // Per stack: its layers as intervals (z from, z to in m, material), air above the top.
    std::vector<uint32_t> mFirst;
    std::vector<double> mFrom, mTo;
    std::vector<uint8_t> mMaterial;
};

/// @brief weight_<material> fog grids (background 0) on the active voxels of @a surface, one
/// per material of @a materials, from the cube of half size max(σ, voxel) around each voxel's
/// closest surface point p − φ∇φ.
std::vector<openvdb::FloatGrid::Ptr> visibleWeights(const Stacks& stacks, const std::vector<Material>& materials,
                                                    double sigma, const openvdb::FloatGrid& surface, Task& task);

} // namespace arches
} // namespace rockvdb
