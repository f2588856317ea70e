// SPDX-License-Identifier: Apache-2.0
// rockvdb — shaded PNG previews of level sets (OpenVDB's LevelSetRayIntersector).
#pragma once

#include <rockvdb/core/Schema.h>

#include <openvdb/openvdb.h>

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace rockvdb {

/// vdb_preview's options, rockvdb.preview's keywords (defaults in previewSchema()).
struct PreviewSettings
{
    PreviewSettings();

    int width, height;  ///< pixels
    double azimuth;     ///< camera direction around z from +x (degrees)
    double elevation;   ///< camera height angle above the xy plane (degrees)
    double fov;         ///< vertical field of view (degrees)
    double zoom;        ///< > 1 moves the camera closer than the framing distance
    /// Albedo (linear RGB in [0, 1]) per id; ids not listed get a colour hashed from the id
    /// (not a row: the CLI's --palette text, Python's dict).
    std::map<int, std::array<double, 3>> palette;
    bool texture;       ///< §6: texture the surface by the material weight grids (PreviewMaterial)
    /// @brief The table's ranges (ValueError naming the row).
    void validate() const;
};

/// @brief The table of PreviewSettings (op "preview").
const Schema<PreviewSettings>& previewSchema();

/// What the image shows: pixels on the surface, and per id (when tinted by an id grid).
struct PreviewStats
{
    size_t pixels = 0;                 ///< width · height
    size_t surfacePixels = 0;          ///< pixels whose ray hits the surface
    std::map<int, size_t> idPixels;    ///< surface pixels per id (ids >= 0)
    std::map<std::string, size_t> materialPixels; ///< textured: surface pixels per dominant material
};

/// A ground material for the texturing of arches §6: its weight grid (a fog grid, the share of
/// its visible faces round each band voxel: vdb_arches' weight_<name>), its colour and pattern.
struct PreviewMaterial
{
    std::string name;                       ///< "sand", "bedrock", "rocks", or another
    openvdb::FloatGrid::ConstPtr weight;
    std::array<double, 3> colour{{0.5, 0.5, 0.5}}; ///< linear albedo
};

/// @brief A ground material's colour (linear RGB in [0, 1]): sand, bedrock and rocks their
/// own, any other name one hashed from it. The one table: vdb_preview --texture and the
/// Blender add-on's default material (through rockvdb.material_colour) read it.
std::array<double, 3> materialColour(const std::string& name);

/// @brief The materials of @a grids' weight_<name> float grids (in their order), each with its
/// materialColour and pattern.
std::vector<PreviewMaterial> previewMaterials(const openvdb::GridPtrVec& grids);

/// @brief The texture of material @a m at @a p (world) for the unit normal @a n: its 2D pattern
/// on the three axis planes, blended triplanarly with Lp weights, p = 8 (arches §6), times its
/// colour. (Per pixel, at the hit point; the paper blends per mesh vertex.)
std::array<double, 3> materialTexture(const PreviewMaterial& m, const openvdb::Vec3d& p, const openvdb::Vec3d& n);

/// @brief Parse "ID=#rrggbb,ID=#rrggbb,..." (sRGB hex colours) into a palette.
/// @throw ValueError naming @a what for malformed entries.
std::map<int, std::array<double, 3>> parsePalette(const std::string& text,
                                                  const std::string& what = "palette");

/// @brief Render @a grid with a key light, sky fill and soft shadowless shading, framing its
/// active bounding box. When @a ids is given (e.g. block_id), surfaces are tinted per id.
/// @return RGB8 pixels, row 0 at the top.
/// @param stats  if given, receives the surface and per-id pixel counts
/// @param materials  with s.texture: the weight grids (previewMaterials); each surface pixel
///   takes Σ w_m T_m / Σ w_m (its weights at the hit point's voxel; ids, if given, are then only
///   counted). @throw ValueError when s.texture has none.
std::vector<uint8_t> renderPreview(const openvdb::FloatGrid& grid, const PreviewSettings& s,
                                   const openvdb::FloatGrid* ids = nullptr,
                                   PreviewStats* stats = nullptr,
                                   const std::vector<PreviewMaterial>* materials = nullptr);

/// @brief renderPreview + PNG, written atomically.
void writePreview(const openvdb::FloatGrid& grid, const std::string& path,
                  const PreviewSettings& s, const openvdb::FloatGrid* ids = nullptr,
                  PreviewStats* stats = nullptr, const std::vector<PreviewMaterial>* materials = nullptr);

} // namespace rockvdb
