// SPDX-License-Identifier: Apache-2.0
// rockvdb — vdb_heightfield and rockvdb.heightfield's front door: a heightfield image baked into
// the level set of the terrain solid, with its parameter table (Heightfield.h gives the
// convention: column i, row j at x = i·cell-size, y = j·cell-size, z = value·height-scale).
#pragma once

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <string>

namespace rockvdb {

/// The tool the entry point records as the generator of what it makes.
constexpr const char* kHeightfieldTool = "vdb_heightfield";

/// vdb_heightfield's options, rockvdb.heightfield's keywords (defaults in heightfieldSchema()).
struct HeightfieldParams
{
    HeightfieldParams();

    double cellSize;    ///< distance between pixel centres (m)
    double heightScale; ///< metres per image unit
    double baseDepth;   ///< floor of the solid below the lowest sample (m)
    BakeParams bake;
};

/// @brief The table of HeightfieldParams (op "heightfield").
const Schema<HeightfieldParams>& heightfieldSchema();

/// @brief Bake the heightfield image @a image (float EXR, metres; or 16-bit PNG, 0..1) into
/// the level set 'surface' of the closed terrain solid (phase: bake); provenance is the table
/// with {"image": image}. Stats: samples [nx, ny] and the bake's.
/// @throw IoError for unreadable images, ValueError for bad values or an empty result.
StageResult runHeightfield(const HeightfieldParams& params, const std::string& image, Task& task);

} // namespace rockvdb
