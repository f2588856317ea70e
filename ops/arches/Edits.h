// SPDX-License-Identifier: Apache-2.0
// rockvdb — editing material stacks ("Arches: a Framework for Modeling Complex Terrains", §4):
// bedrock sculpting with a point primitive (§4.1), granular deposits (§4.3) and erosion
// (§4.4). An edit is a JSON object, {"tool": ..., keys}, as a scene's "edits" list holds them
// and rockvdb.Stacks' methods make them; each is local — it reads and rewrites only the stacks
// it reaches (Stacks::window / Stacks::edit) and is followed by a local stabilisation
// (stabilizeLocal), so its cost follows the edited region, not the terrain.
//
// Tools (editTools() describes every key with its default and help):
//   sculpt  — "points" (targets v, or with "at": "center" the centres c), "radius" R, "mode"
//             add | carve, "depth" δ (default R/2), "strength" k: at each point, in turn,
//             f_e = f ± k·f*, f* = g(‖p − c‖), g(r) = (1 − (r/R)²)² (r < R), where f is the
//             bedrock's convolution field (§3.3), v is projected on the bedrock surface and
//             c = v ∓ δ·n (n the outward normal); the stacks within R of c are re-split into
//             bedrock / not bedrock by the roots of f_e along their axes inside the ball
//             (granular material and air keep their place where f_e stays outside).
//   deposit — "material" sand | rocks, "center" [x, y], "radius" R, "amount" h (m at the
//             centre), "profile" smooth | flat, optional "z": drop on each stack's ground top
//             (default) or into the room containing height z (a cave's floor).
//   erode   — "center" [x, y, z] or a stroke "points", "radius" R (the sphere, or the tube it
//             sweeps along the stroke's segments), "mode" surface | collapse: surface turns the
//             bedrock within "depth" of an exposed face (a top or an overhang's underside)
//             inside the region into sand; collapse turns all the bedrock inside it into rocks
//             (share "rho") and sand. Bedrock removed = granular added, exactly.
//   stabilize — a global stabilisation (what Stacks.stabilize() records after edits).
#pragma once

#include <rockvdb/arches/Stabilize.h>
#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>

#include <string>

namespace rockvdb {
namespace arches {

/// What an edit needs beyond its own keys: the scene's σ and repose angles.
struct EditContext
{
    double sigma = 0.5;  ///< m (the bedrock field's kernel half size)
    ReposeAngles angles;
};

struct EditStats
{
    std::string tool;
    size_t stacks = 0;           ///< stacks the edit rewrote (before stabilisation)
    int i0 = 0, j0 = 0, i1 = -1, j1 = -1; ///< their bounding window (i1 < i0: none)
    int64_t bedrock = 0, sand = 0, rocks = 0; ///< change of each material (quanta)
    StabilizeStats stabilize;
    double seconds = 0;          ///< the edit and its stabilisation
};

/// @brief Every tool's keys: {tool: {"help": text, "keys": [{"name", "type", "default",
/// "help", "required", "range" (text or null), "choices"}...]}}; "default" null = none (or
/// computed as the help says). The one place a key's default, range and values live.
const nlohmann::json& editTools();

/// @brief Edit @a e with every key it leaves out that has a default set to it (what the
/// edit runs with). @a e must name a known tool.
nlohmann::json withDefaults(const nlohmann::json& e);

/// @brief Check edit @a index (its tool, keys, types and ranges). @throw ValueError
/// "arches: edits[index] (tool): ..." naming the key.
void validateEdit(const nlohmann::json& edit, size_t index);

/// @brief Apply edit @a index to @a stacks and stabilise what it changed (a "stabilize" edit:
/// all of them). @throw ValueError as validateEdit does, and for an edit outside the terrain;
/// the stacks are then unchanged. Interrupted (Task) leaves them unchanged too.
EditStats applyEdit(Stacks& stacks, const nlohmann::json& edit, size_t index, const EditContext& ctx,
                    Task& task);

} // namespace arches
} // namespace rockvdb
