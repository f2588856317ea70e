// SPDX-License-Identifier: Apache-2.0
// rockvdb — initial material stacks: from a heightfield, or from any solid (a level set, a JSON
// expression) by the roots of f = 0 along each stack's axis, so overhangs in the input survive
// ("Arches: a Framework for Modeling Complex Terrains", §3.2, §4.1: stacks are re-split into
// bedrock / air by the roots of the field along their central axis).
#pragma once

#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/Field.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/Task.h>

#include <vector>

namespace rockvdb {
namespace arches {

/// @brief One stack per heightfield sample, centred on it (stack (i, j) covers x in
/// [(i − ½)·c, (i + ½)·c)): bedrock from @a z0 up to h − sand, then sand up to h, where sand
/// is @a sandDepth (m) or, when given, @a sandMap[j·nx + i]. Heights are rounded to whole
/// quanta of @a quantum. @throw ValueError for a sample below z0 or a negative depth.
Stacks stacksFromHeightfield(const Heightfield& hf, double quantum, double z0, double sandDepth,
                             const std::vector<float>* sandMap, Task& task);

/// One stratum of a procedural terrain: a material and its thickness (m).
struct Stratum
{
    Material material = Material::Bedrock;
    double thickness = 1.0;
};

/// Procedural strata: the terrain's top h(x, y) = base + amplitude · fbm(x, y) / Σgain, cut
/// through strata laid bottom up from z0 whose boundaries are each warped by their own fBm of
/// @c warp metres; the last stratum reaches the top. An air stratum inside the ground is a
/// band of overhangs and caves wherever the ground stands above it.
struct StrataSpec
{
    StackGeometry geometry;
    std::vector<Stratum> strata;
    double base = 10.0, amplitude = 5.0, frequency = 0.02; ///< the top (m, m, 1/m)
    double warp = 1.0, warpFrequency = 0.05;               ///< boundary warp (m, 1/m)
    int octaves = 5;
    uint64_t seed = 0;
};

/// @brief Stacks of procedural strata (see StrataSpec). @throw ValueError for no strata or
/// a negative thickness.
Stacks stacksFromStrata(const StrataSpec& spec, Task& task);

/// @brief Stacks of @a material where @a solid is inside (f < 0), from the roots of f along each
/// stack's central axis, sampled every @a step metres from geometry.z0 to the top of the
/// solid's bounds and located between samples by linear interpolation (exact for a level
/// set's trilinear interpolation when step is its voxel size). Everything below z0 is cut.
/// @throw ValueError if the solid is unbounded above.
Stacks stacksFromSolid(const Field& solid, const StackGeometry& geometry, double step,
                       Material material, Task& task);

} // namespace arches
} // namespace rockvdb
