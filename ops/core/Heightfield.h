// rockvdb — heightfield terrains as fields.
//
// Convention (DESIGN.md): pixel column i, row j (row 0 = first row stored in the file) sits at
// world x = i·cellSize, y = j·cellSize with height z = value·heightScale. EXR values are
// metres before scaling; 16-bit PNG values map 0..65535 to 0..1 before scaling.
//
// The surface is the heightfield triangulated along each cell's (i, j)–(i+1, j+1) diagonal.
// The field is the closed terrain solid {(x, y) in the footprint, base <= z <= h(x, y)}: its
// value is the exact Euclidean distance to the triangulated surface within exactDistance of
// it (steep slopes included), intersected with the footprint walls and the floor.
#pragma once

#include "Field.h"
#include "Noise.h"

#include <memory>
#include <string>
#include <vector>

namespace rockvdb {

struct Heightfield
{
    int nx = 0, ny = 0;      ///< samples along x (columns) and y (rows)
    double cellSize = 1.0;   ///< spacing of samples (m)
    std::vector<float> z;    ///< heights (m), z[j·nx + i]

    float at(int i, int j) const { return z[size_t(j) * size_t(nx) + size_t(i)]; }
    double width() const { return (nx - 1) * cellSize; }
    double depth() const { return (ny - 1) * cellSize; }
    void validate(const char* op) const;
};

/// @brief Load an EXR / 16-bit PNG heightfield (see file comment for the convention).
/// @param cellSize     sample spacing (m), > 0
/// @param heightScale  metres per image unit, finite
Heightfield loadHeightfield(const std::string& path, double cellSize, double heightScale);

/// @brief A procedural fBm heightfield: z = amplitude · fbm2(x, y) / Σgain (m).
Heightfield noiseHeightfield(int nx, int ny, double cellSize, double amplitude,
                             const noise::Fbm& fbm, uint64_t seed);

struct HeightfieldSettings
{
    double baseDepth = 1.0;     ///< floor of the solid: this far below the lowest sample (m)
    /// Distance up to which values are exact (m) when the caller gives no reach; batches from
    /// the baker carry the distance they need (Batch::reach) and are exact within it.
    double exactDistance = 1.0;
};

/// @brief The closed terrain solid as a field (exact distance near the surface).
FieldPtr heightfieldField(std::shared_ptr<const Heightfield> hf, const HeightfieldSettings& s);

} // namespace rockvdb
