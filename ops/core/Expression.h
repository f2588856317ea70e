// SPDX-License-Identifier: Apache-2.0
// rockvdb — fields from JSON expressions (vdb_primitive expr, samples, Python).
//
// A node is an object with a "type" and its parameters; any node may carry "id" (an integer
// below 2^24) to tag its sub-field for attribute grids. Units are metres and degrees.
//   {"type": "sphere", "center": [x,y,z], "radius": r}
//   {"type": "box", "center": [x,y,z], "size": [sx,sy,sz], "rounding": r}
//   {"type": "capsule", "a": [x,y,z], "b": [x,y,z], "radius": r}
//   {"type": "plane", "point": [x,y,z], "normal": [x,y,z]}          (unbounded)
//   {"type": "polytope", "planes": [[nx,ny,nz,d], ...], "smooth": R}  (n·p <= d inside)
//   {"type": "union" | "intersection" | "difference", "children": [...], "smooth": R}
//   {"type": "transform", "translate": [..], "rotate": [rx,ry,rz], "scale": s | [..],
//    "child": {...}}
//   {"type": "warp", "amplitude": a, "frequency": f, "octaves": n, "seed": s,
//    "lacunarity": l, "gain": g, "child": {...}}
//   {"type": "heightfield", "file": "terrain.exr", "cell_size": c, "height_scale": h,
//    "base_depth": d}                        (relative paths are relative to the JSON file)
//   {"type": "noise_terrain", "samples": [nx, ny], "cell_size": c, "amplitude": a,
//    "frequency": f, "octaves": n, "seed": s, "base_depth": d}
//   {"type": "sea_cliff", "samples": [nx, ny], "cell_size": c, "height": h, "floor": f,
//    "coast": x, "width": w, "waviness": a, "coast_frequency": f, "roughness": r,
//    "roughness_frequency": f, "seed": s, "base_depth": d}   (see SeaCliff in Heightfield.h)
// Unknown keys are errors (they are usually typos); messages give the JSON path.
#pragma once

#include <rockvdb/core/Field.h>
#include <rockvdb/core/Json.h>

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace rockvdb {

struct ExpressionContext
{
    std::string baseDir = ".";   ///< folder for relative file paths
    uint64_t seed = 0;           ///< default seed of warps and noise terrains
};

/// @brief Build a field from a parsed expression. @throw ValueError with the JSON path.
FieldPtr fieldFromJson(const nlohmann::json& node, const ExpressionContext& ctx);

struct Heightfield;

/// A heightfield node (heightfield, noise_terrain, sea_cliff) as its heightfield and floor,
/// for consumers that use the heightfield itself (vdb_amplify's exact terrain distance and
/// footprint).
struct HeightfieldNode
{
    std::shared_ptr<const Heightfield> heightfield;
    double baseDepth = 1.0;
};

/// @brief The heightfield of @a node when it is a heightfield node; nullopt otherwise.
/// @throw ValueError with the JSON path for a malformed heightfield node.
std::optional<HeightfieldNode> heightfieldFromJson(const nlohmann::json& node,
                                                   const ExpressionContext& ctx);

/// @brief Parse text then build. @throw ValueError for malformed JSON (with line/column).
FieldPtr fieldFromJsonText(const std::string& text, const ExpressionContext& ctx);

} // namespace rockvdb
