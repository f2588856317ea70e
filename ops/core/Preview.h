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
};

/// @brief Parse "ID=#rrggbb,ID=#rrggbb,..." (sRGB hex colours) into a palette.
/// @throw ValueError naming @a what for malformed entries.
std::map<int, std::array<double, 3>> parsePalette(const std::string& text,
                                                  const std::string& what = "palette");

/// @brief Render @a grid with a key light, sky fill and soft shadowless shading, framing its
/// active bounding box. When @a ids is given (e.g. block_id), surfaces are tinted per id.
/// @return RGB8 pixels, row 0 at the top.
/// @param stats  if given, receives the surface and per-id pixel counts
std::vector<uint8_t> renderPreview(const openvdb::FloatGrid& grid, const PreviewSettings& s,
                                   const openvdb::FloatGrid* ids = nullptr,
                                   PreviewStats* stats = nullptr);

/// @brief renderPreview + PNG, written atomically.
void writePreview(const openvdb::FloatGrid& grid, const std::string& path,
                  const PreviewSettings& s, const openvdb::FloatGrid* ids = nullptr,
                  PreviewStats* stats = nullptr);

} // namespace rockvdb
