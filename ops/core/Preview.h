// rockvdb — shaded PNG previews of level sets (OpenVDB's LevelSetRayIntersector).
#pragma once

#include <openvdb/openvdb.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rockvdb {

struct PreviewSettings
{
    int width = 960, height = 540;  ///< pixels
    double azimuth = 35.0;          ///< camera direction around z from +x (degrees)
    double elevation = 30.0;        ///< camera height angle above the xy plane (degrees)
    double fov = 35.0;              ///< vertical field of view (degrees)
    double zoom = 1.0;              ///< > 1 moves the camera closer than the framing distance
    void validate() const;
};

/// @brief Render @a grid with a key light, sky fill and soft shadowless shading, framing its
/// active bounding box. When @a ids is given (e.g. block_id), surfaces are tinted per id.
/// @return RGB8 pixels, row 0 at the top.
std::vector<uint8_t> renderPreview(const openvdb::FloatGrid& grid, const PreviewSettings& s,
                                   const openvdb::FloatGrid* ids = nullptr);

/// @brief renderPreview + PNG, written atomically.
void writePreview(const openvdb::FloatGrid& grid, const std::string& path,
                  const PreviewSettings& s, const openvdb::FloatGrid* ids = nullptr);

} // namespace rockvdb
