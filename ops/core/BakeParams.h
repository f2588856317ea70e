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

struct BakeParams
{
    std::optional<double> voxelSize;  ///< m; unset: the stage's own rule (e.g. the input's)
    std::optional<double> halfWidth;  ///< voxels; unset: the stage's own rule
    std::string renormalize = "auto";
    int trackerSteps = 0;
    std::optional<std::array<double, 6>> region; ///< xmin,ymin,zmin,xmax,ymax,zmax (m)
    double maxMemoryGB = 0;           ///< 0 = 75% of RAM

    /// @brief The BakeSettings these give, unset sizes taken from the arguments (stages whose
    /// table gives the sizes a default call it without).
    BakeSettings settings(double voxelSizeIfUnset = std::numeric_limits<double>::quiet_NaN(),
                          double halfWidthIfUnset = std::numeric_limits<double>::quiet_NaN()) const;
};

/// @brief The bake rows of a stage's table, bound to member @a m of its Params. @a voxelSize
/// and @a halfWidth are the stage's defaults (null: "the input's", said in @a sizeNote).
template<typename P>
void addBakeRows(Schema<P>& s, BakeParams P::*m, nlohmann::json voxelSize,
                 nlohmann::json halfWidth, const char* sizeNote = "")
{
    using schema_detail::Conv;
    auto bind = [&](ParamInfo info, auto BakeParams::*field) {
        using T = std::remove_reference_t<decltype(std::declval<BakeParams>().*field)>;
        s.add(std::move(info),
              [m, field](const P& p) { return Conv<T>::get((p.*m).*field); },
              [m, field](P& p, const nlohmann::json& j) { Conv<T>::set((p.*m).*field, j); });
    };
    const std::string note = sizeNote;
    bind(param("voxel-size", ParamType::Real, "m", voxelSize, Range::closed(1e-6, 1e6),
             "Voxel edge length" + (voxelSize.is_null() ? note : std::string())),
         &BakeParams::voxelSize);
    bind(param("half-width", ParamType::Real, "voxels", halfWidth, Range::closed(1, 64),
             "Narrow-band half width" + (halfWidth.is_null() ? note : std::string())),
         &BakeParams::halfWidth);
    ParamInfo renorm = param("renormalize", ParamType::Text, "", "auto", Range::any(),
                           "Renormalise fields that are not exact distances: auto (those), on, off");
    renorm.choices = {"auto", "on", "off"};
    bind(renorm, &BakeParams::renormalize);
    bind(param("tracker-steps", ParamType::Int, "", 0, Range::closed(0, 100),
             "LevelSetTracker normalise steps after baking"), &BakeParams::trackerSteps);
    bind(param("region", ParamType::Reals, "m", nullptr, Range::any(),
             "Bake only voxel centres in [min, max): xmin,ymin,zmin,xmax,ymax,zmax "
             "(leaf-aligned regions chunk a bake bit for bit)", 6),
         &BakeParams::region);
    bind(param("max-memory", ParamType::Real, "GB", 0.0, Range::atLeast(0),
             "Refuse bakes estimated above this (0 = 75% of RAM)"), &BakeParams::maxMemoryGB);
}

} // namespace rockvdb
