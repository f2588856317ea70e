// SPDX-License-Identifier: Apache-2.0
// rockvdb — the generic sparse narrow-band baker (one baker serves every stage).
//
// bake() turns a Field into a well-formed OpenVDB level set:
//  1. hierarchical culling: the domain is split into power-of-two nodes; a node is skipped
//     when |f(centre)| > L·halfDiagonal + band, so cost follows surface area, not volume;
//  2. leaf-direct filling, TBB-parallel over surviving 8³ leaves: 512 values in one batch,
//     clamped to ±background (so inactive voxels already carry the field's sign), value
//     mask built 64 bits at a time (SSE2 compare + movemask);
//  3. optional first-order renormalisation f/|∇f| on a padded 10³ block per leaf (a pure
//     function of the leaf, so chunked bakes stay exact), optional LevelSetTracker steps;
//  4. tree assembly in parallel per level-1 node (128³), then OpenVDB's SignedFloodFillOp
//     on the internal nodes and root only; grid class level set, background
//     halfWidth·voxelSize.
// Every voxel value is a pure function of its index: results are bitwise identical for any
// thread count and for any leaf-aligned chunking of the region.
#pragma once

#include <rockvdb/core/Chunks.h>
#include <rockvdb/core/Field.h>

#include <openvdb/Grid.h>
#include <openvdb/openvdb.h>
#include <openvdb/util/NullInterrupter.h>

#include <optional>
#include <string>

namespace rockvdb {

enum class Renormalize { Auto, Off, On };

/// @brief Parse "auto" / "off" / "on" (ValueError otherwise).
Renormalize renormalizeFromString(const std::string& s);

struct BakeSettings
{
    double voxelSize = 0.05;     ///< voxel edge (m), > 0
    double halfWidth = 3.0;      ///< narrow-band half width (voxels), >= 1
    /// World region to bake, half-open [min, max) on voxel centres; unset = the field's
    /// bounds. Leaf-aligned regions (multiples of 8·voxelSize) chunk a bake exactly.
    std::optional<BBoxd> region;
    /// Bake one chunk of the whole (core/Chunks.h): the box the bake would fill, cut on leaf
    /// faces; the chunks merged (core/Merge.h) are the whole bake bit for bit.
    ChunkSpec chunk;
    /// Auto renormalises fields that are not exact distances (Field::exact() == false).
    Renormalize renormalize = Renormalize::Auto;
    double renormBandScale = 2.0; ///< band widening while renormalising (>= 1)
    int trackerSteps = 0;         ///< tools::LevelSetTracker normalise steps afterwards
    bool withAttribute = false;   ///< also build an id grid over the same active voxels
    std::string gridName = "surface";
    std::string attributeName = "block_id";
    double maxMemoryBytes = 0;    ///< refuse bakes estimated above this; 0 = 75% of RAM
    /// Optional candidate topology (index space of this bake): exactly the leaves where it
    /// holds an active voxel or tile are filled, and the field is not culled. Operators that
    /// know where their surface can be (detail within A of its input) pass it to skip leaves
    /// whose values only bound the distance; it must cover the whole band.
    openvdb::MaskGrid::ConstPtr candidates;
    /// With candidates: also a voxel mask, and the sign of the voxels it leaves off. Those
    /// voxels are not evaluated: they stay inactive at ±background with the sign this level
    /// set (same index space) has there. Only the mask's voxels and, when renormalising, their
    /// six neighbours are evaluated (detail: its surface lies within A of its input, whose
    /// widened band gives the mask; beyond it the field only holds bounds, which must not
    /// fake band voxels, and the sign is the input's).
    openvdb::FloatGrid::ConstPtr candidateSigns;

    /// @brief ValueError("bake: ...") unless every setting is usable.
    void validate() const;
};

struct BakeStats
{
    size_t candidateLeaves = 0; ///< leaves that survived culling
    size_t leaves = 0;          ///< leaves holding active voxels
    size_t activeVoxels = 0;
    size_t fieldEvaluations = 0;
    double cullSeconds = 0, fillSeconds = 0, finishSeconds = 0;
    bool renormalized = false;
};

struct BakeResult
{
    openvdb::FloatGrid::Ptr surface;   ///< level set named settings.gridName
    openvdb::FloatGrid::Ptr attribute; ///< ids (class unknown, background -1) or null
    BakeStats stats;
};

/// @brief Estimated peak bytes of a bake and its active voxel count (before allocating).
struct BakeEstimate
{
    double bytes = 0;
    double activeVoxels = 0;
    openvdb::CoordBBox indexBox; ///< voxels that may be evaluated (this chunk's)
    openvdb::CoordBBox wholeBox; ///< the whole bake's (= indexBox unless chunked)
    bool empty = false;
};
BakeEstimate estimateBake(const Field& field, const BakeSettings& settings);

/// @brief estimateBake, and the refusal bake() makes when it is over the memory limit.
/// @throw ValueError as bake() does for an estimate above settings.maxMemoryBytes.
BakeEstimate checkedEstimate(const Field& field, const BakeSettings& settings);

/// @brief The half-open world region whose voxel centres are exactly @a box at @a voxelSize
/// (BakeSettings::region): bakes of several fields over one box (their parts) agree voxel
/// for voxel.
BBoxd regionOfBox(const openvdb::CoordBBox& box, double voxelSize);

/// @brief Bake @a field into a narrow-band level set.
/// @throw ValueError for bad settings, an unbounded field without a region, a bake whose
///        memory estimate exceeds the limit (the message gives the estimate), or NaN values.
/// @throw Interrupted when @a interrupt asks to stop (checked once per leaf batch).
/// @note Progress is reported through interrupt->wasInterrupted(percent).
BakeResult bake(const Field& field, const BakeSettings& settings,
                openvdb::util::NullInterrupter* interrupt = nullptr);

/// @brief Total physical memory of this machine (bytes).
double physicalMemoryBytes();

/// @brief The memory limit a --max-memory of @a maxBytes means: itself, or 75% of RAM for 0.
double memoryLimitBytes(double maxBytes);

/// @brief "1.2 GB" style formatting of a byte count.
std::string formatBytes(double bytes);

} // namespace rockvdb
