// SPDX-License-Identifier: Apache-2.0
// rockvdb — the bake's rows in every baking stage's table: voxel size, band, renormalisation,
// tracker steps, region and memory limit, named and checked the same way in every tool.
#pragma once

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Schema.h>

#include <array>
#include <limits>
#include <optional>
#include <string>

namespace rockvdb {

/// The `chunks` and `chunk` rows' values (core/Chunks.h: ChunkSpec::parse reads them).
struct ChunkParams
{
    std::string chunks; ///< "AxBxC" split of the whole bake ("" = chosen for chunk's N)
    std::string chunk;  ///< "i/N": bake chunk i only ("" = the whole)

    /// The rows' names in every table (addChunkRows) and in provenance (wholeBakeParams).
    static constexpr const char* kChunksRow = "chunks";
    static constexpr const char* kChunkRow = "chunk";

    ChunkSpec spec(const char* op) const { return ChunkSpec::parse(chunks, chunk, op); }
};

/// The bake's rows' values. The member initialisers are the rows' defaults (addBakeRows reads
/// them, as it reads the sizes from BakeSettings): written once, here.
struct BakeParams
{
    std::optional<double> voxelSize;  ///< m; unset: the stage's own rule (e.g. the input's)
    std::optional<double> halfWidth;  ///< voxels; unset: the stage's own rule
    std::string renormalize = "auto";
    int trackerSteps = 0;
    std::optional<std::array<double, 6>> region; ///< xmin,ymin,zmin,xmax,ymax,zmax (m)
    double maxMemoryGB = 0;           ///< 0 = 75% of RAM
    ChunkParams chunking;             ///< one chunk of the whole bake, or the whole

    /// @brief The BakeSettings these give, unset sizes taken from the arguments (stages whose
    /// table gives the sizes a default call it without).
    BakeSettings settings(double voxelSizeIfUnset = std::numeric_limits<double>::quiet_NaN(),
                          double halfWidthIfUnset = std::numeric_limits<double>::quiet_NaN()) const;
};

/// The rockvdb defaults of a bake's sizes: BakeSettings' own, which every table that gives
/// its bake rows a default reads (addBakeRows' voxelSize / halfWidth).
inline double defaultVoxelSize() { return BakeSettings().voxelSize; }
inline double defaultHalfWidth() { return BakeSettings().halfWidth; }

/// @brief The `chunks` and `chunk` rows of a stage's table; @a access maps a Params (const or
/// not) to its ChunkParams (stages that bake without BakeParams use it too).
template<typename P, typename Access>
void addChunkRows(Schema<P>& s, Access access)
{
    // Defaults: the members' own (a whole bake), which wholeBakeParams puts back.
    const ChunkParams whole;
    auto resolution = [](ParamInfo row) { row.resolution = true; return row; };
    s.add(resolution(param(ChunkParams::kChunksRow, ParamType::Text, "", whole.chunks, Range::any(),
                "Split of the whole bake into AxBxC chunks on leaf faces, e.g. 4x4x1 (with chunk; "
                "empty: chosen for chunk's N)")),
          [access](const P& p) { return nlohmann::json(access(p).chunks); },
          [access](P& p, const nlohmann::json& j) { access(p).chunks = j.get<std::string>(); });
    s.add(resolution(param(ChunkParams::kChunkRow, ParamType::Text, "", whole.chunk, Range::any(),
                "Bake only chunk i/N (from 0) of the whole; vdb_merge unites the N chunk files "
                "into the whole bake, bit for bit (empty: the whole)")),
          [access](const P& p) { return nlohmann::json(access(p).chunk); },
          [access](P& p, const nlohmann::json& j) { access(p).chunk = j.get<std::string>(); });
}

/// @brief The bake rows of a stage's table, bound to member @a m of its Params. @a voxelSize
/// and @a halfWidth are the stage's defaults (null: "the input's", said in @a sizeNote).
template<typename P>
void addBakeRows(Schema<P>& s, BakeParams P::*m, nlohmann::json voxelSize,
                 nlohmann::json halfWidth, const char* sizeNote = "")
{
    using schema_detail::Conv;
    // Every bake row samples the same shape: resolution rows (ParamInfo::resolution).
    auto bind = [&](ParamInfo info, auto BakeParams::*field) {
        using T = std::remove_reference_t<decltype(std::declval<BakeParams>().*field)>;
        info.resolution = true;
        s.add(std::move(info),
              [m, field](const P& p) { return Conv<T>::get((p.*m).*field); },
              [m, field](P& p, const nlohmann::json& j) { Conv<T>::set((p.*m).*field, j); });
    };
    const std::string note = sizeNote;
    const BakeParams defaults;
    bind(voxelSizeRow(voxelSize, "Voxel edge length" + (voxelSize.is_null() ? note : std::string())),
         &BakeParams::voxelSize);
    bind(halfWidthRow(halfWidth, "Narrow-band half width" + (halfWidth.is_null() ? note : std::string())),
         &BakeParams::halfWidth);
    ParamInfo renorm = param("renormalize", ParamType::Text, "", defaults.renormalize, Range::any(),
                           "Renormalise fields that are not exact distances: auto (those), on, off");
    renorm.choices = {"auto", "on", "off"};
    bind(renorm, &BakeParams::renormalize);
    bind(param("tracker-steps", ParamType::Int, "", defaults.trackerSteps, Range::closed(0, 100),
             "LevelSetTracker normalise steps after baking"), &BakeParams::trackerSteps);
    bind(param("region", ParamType::Reals, "m", nullptr, Range::any(),
             "Bake only voxel centres in [min, max): xmin,ymin,zmin,xmax,ymax,zmax "
             "(leaf-aligned regions chunk a bake bit for bit)", 6),
         &BakeParams::region);
    bind(maxMemoryRow("Refuse bakes estimated above this (0 = 75% of RAM)"), &BakeParams::maxMemoryGB);
    addChunkRows(s, [m](auto& p) -> auto& { return (p.*m).chunking; });
}

/// The bake's rows alone, with the default sizes: what baking a field takes (rockvdb.Field.bake).
struct FieldBakeParams
{
    BakeParams bake;
};

/// @brief The table of FieldBakeParams (op "bake").
const Schema<FieldBakeParams>& fieldBakeSchema();

} // namespace rockvdb
