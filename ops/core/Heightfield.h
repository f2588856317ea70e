// SPDX-License-Identifier: Apache-2.0
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

#include <rockvdb/core/Field.h>
#include <rockvdb/core/Noise.h>

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
Heightfield loadHeightfield(const std::string& path, double cellSize, double heightScale,
                            double maxMemoryBytes = 0);

/// @brief A procedural fBm heightfield: z = amplitude · fbm2(x, y) / Σgain (m).
Heightfield noiseHeightfield(int nx, int ny, double cellSize, double amplitude,
                             const noise::Fbm& fbm, uint64_t seed);

/// A procedural sea cliff: a plateau falling to a sea floor along a wavy coastline that runs
/// along y, its top and foot rounded by a smoothstep, with fBm roughness over everything.
/// z(x, y) = floor + (height − floor)·S(t) + roughness·fbm(x, y)/Σgain, S(t) = t²(3 − 2t),
/// t = clamp((c(y) − x)/width + ½, 0, 1), the coastline c(y) = coast + waviness·(0.7 sin(ωy +
/// φ₀) + 0.3 sin(2.3ωy + φ₁)) + ½·waviness·fbm(y)/Σgain with ω = 2π·coastFrequency and phases
/// from the seed: the plateau is at small x, the face's steepest slope is
/// 1.5·(height − floor)/width at its mid-line.
struct SeaCliff
{
    int nx = 161, ny = 161;         ///< samples along x and y
    double cellSize = 0.5;          ///< m
    double height = 25.0;           ///< plateau (m)
    double floor = 0.0;             ///< sea floor (m)
    double coast = 40.0;            ///< x of the face's mid-line (m)
    double width = 8.0;             ///< horizontal extent of the face (m)
    double waviness = 4.0;          ///< coastline amplitude: bays and headlands (m)
    double coastFrequency = 0.05;   ///< coastline wiggles per metre along y
    double roughness = 0.6;         ///< fBm amplitude over the whole surface (m)
    double roughnessFrequency = 0.08; ///< 1/m
    uint64_t seed = 1;
    void validate() const;
};

/// @brief Sample a SeaCliff into a heightfield.
Heightfield seaCliffHeightfield(const SeaCliff& c);

struct HeightfieldSettings
{
    double baseDepth = 1.0;     ///< floor of the solid: this far below the lowest sample (m)
    /// Distance up to which values are exact (m) when the caller gives no reach; batches from
    /// the baker carry the distance they need (Batch::reach) and are exact within it.
    double exactDistance = 1.0;
    /// true: the closed solid (footprint walls and floor); false: the open height surface
    /// alone, what terrain-following rules (amplify's presence) read near the footprint's
    /// edges, where the solid's side walls are not terrain.
    bool closed = true;
};

/// @brief The closed terrain solid as a field (exact distance near the surface).
FieldPtr heightfieldField(std::shared_ptr<const Heightfield> hf, const HeightfieldSettings& s);

} // namespace rockvdb
