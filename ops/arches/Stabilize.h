// SPDX-License-Identifier: Apache-2.0
// rockvdb — stabilisation of material stacks ("Arches: a Framework for Modeling Complex
// Terrains", §3.4, Figures 6–8).
//
// Bedrock never moves. The rest of a stack is a list of *segments*: the room between two
// bedrock layers (a cave, an overhang's underside), between the floor and the first bedrock,
// and above the last bedrock (open to the sky). Within a segment the granular layers are merged
// and sorted sand < rocks < water < air (Fig. 6); then sand, and after it rocks, slide to the 8
// neighbouring stacks while a slope exceeds the material's repose angle α (Fig. 7–8).
//
// The slide (§3.4): from a segment whose pile top stands Δh_i above a neighbour's, with
// Δh̃_i = max(0, Δh_i − d_i·tan α), material moves to the neighbours in proportion to Δh̃_i.
// The paper moves a small constant a per step; here a step moves half the largest excess (at
// least one quantum), which converges without oscillation (the giver never drops below half way
// to the receiver nearest the threshold's mid-point) and in far fewer steps. d_i is the distance
// to the neighbour (s, or s·√2 on diagonals; the paper uses s for all eight).
//
// A neighbour takes part when the pile top's height is open room there (not inside its bedrock)
// and its segment has room left (a cave fills up). Thicknesses are whole quanta moved between
// integers, so every material's volume is conserved exactly; the work is a FIFO worklist of
// segments whose neighbourhood changed (not full sweeps), visited in a fixed order, one thread:
// the result does not depend on thread count. Stable means: no pile top with material stands
// more than d_i·tan α + 1 quantum above an open neighbour (a step moves ⌊excess / 2⌋).
#pragma once

#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/Task.h>

namespace rockvdb {
namespace arches {

struct ReposeAngles
{
    double sand = 33.0;  ///< degrees (the paper: 30–35)
    double rocks = 42.0; ///< degrees (the paper: 40–45)

    /// @brief ValueError unless both lie in (0, 90).
    void validate() const;
};

struct StabilizeStats
{
    size_t visits = 0;  ///< segments taken from the worklist
    size_t moves = 0;   ///< steps that moved material
    uint64_t movedQuanta = 0;
    double seconds = 0;
};

/// @brief Merge and sort the granular layers of every segment (Fig. 6) without sliding.
Stacks normalizeStacks(const Stacks& stacks, Task& task);

/// @brief Normalise, then slide sand and then rocks until stable (see file comment).
Stacks stabilizeStacks(const Stacks& stacks, const ReposeAngles& angles, Task& task,
                       StabilizeStats* stats = nullptr);

/// @brief The largest excess over the repose threshold left anywhere (quanta; <= 1 once
/// stable), for @a material (sand or rocks): how tests and tools check a result.
/// @brief Stabilise after a local change of the stacks in [i0, i1] × [j0, j1], in place, the
/// rest taken as already stable: stabilizeStacks' slides from a worklist of those stacks and
/// their 8 neighbours (in index order), run on a window of the stacks around them that
/// doubles (the run starting over) until the slides stay inside it, so the result does not
/// depend on the window and the cost follows the material moved, not the terrain. Only the
/// stacks it changed (and the seeds, merged and sorted) are written back.
StabilizeStats stabilizeLocal(Stacks& stacks, const ReposeAngles& angles, int i0, int j0, int i1, int j1,
                              Task& task);

double largestExcess(const Stacks& stacks, Material material, double angleDegrees);

} // namespace arches
} // namespace rockvdb
