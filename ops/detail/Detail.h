// SPDX-License-Identifier: Apache-2.0
// rockvdb — surface detail on any level set (issue 5):
//  - the gradient-based triplanar warp of implicit-blocks-rocky-scenery.txt §4.2,
//    ω⁻¹(p) = p + δ(p), δ(p) = g(p) Σ_i α_i(g(p)) d(γ_i(p)), g the normalised gradient;
//  - Gabor surface details of gabor-details-implicit-surfaces.txt §3–§4: for p in the band
//    |f| < R, p_S = proj(p, v_{α,θ}) on the surface, f(p) ← f(p) - D(n(p_S))·K(|p p_S| / R),
//    K(r) = (1 - r)⁶, with the noise's frames (n, t, b) from the normal and a direction field.
// Both take any Field (a baked grid through levelSetField, or a library field) and give a
// Field to bake with renormalisation.
#pragma once

#include <rockvdb/relief/Relief.h>

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Field.h>

#include <openvdb/openvdb.h>

#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace rockvdb {
namespace detail {

using relief::ReliefParams;

/// Where the noise's tangent direction W comes from (gabor §3): b = n ∧ W, t = b ∧ n.
enum class DirectionKind { Axis, Skeleton, Curvature };

/// One skeleton primitive (gabor §3): a point, a segment or a triangle (@c count 1, 2, 3
/// vertices), its radius of influence and weight: f_i(P) = weight·(1 − d²/radius²)³ with d the
/// distance from P to the primitive, W(P) = Σ_i f_i(P) S_i (the weighted skeleton direction
/// WdS). S_i: a segment's (b − a)/|b − a|; for a triangle "any vector included in its defining
/// plane" — the given direction projected into it, by default a → b; a point has no direction
/// of its own: the given one, by default +z. Polylines are runs of segments.
/// The paper's future work, "detail parameters stored along the skeleton": each primitive may
/// carry a Gabor amplitude, frequency and tilt per vertex (NaN: the stage's own), interpolated
/// at the primitive's point nearest P (linearly along a segment, barycentrically on a
/// triangle); the value at P is (Σ f_i v_i + (1 − Σ f_i)⁺ v) / (Σ f_i + (1 − Σ f_i)⁺) with v
/// the stage's own: the skeleton's where the primitives weigh 1 or more, fading to the stage's
/// at the edge of their reach.
struct Primitive
{
    int count = 2;
    Vec3d v[3];
    double radius = 1.0;
    double weight = 1.0;
    Vec3d direction = Vec3d(0, 0, 1); ///< S_i (unit), set by the JSON reader
    /// Per vertex (NaN = unset): Gabor amplitude (m), frequency (cycles/m), tilt α (degrees).
    std::array<double, 3> amplitude{kUnset, kUnset, kUnset}, frequency{kUnset, kUnset, kUnset},
        tilt{kUnset, kUnset, kUnset};
    static constexpr double kUnset = std::numeric_limits<double>::quiet_NaN();
};

struct DirectionField
{
    DirectionKind kind = DirectionKind::Axis;
    Vec3d axis = Vec3d(0, 0, 1);
    std::vector<Primitive> primitives;
    /// @brief {"segments": [{"a", "b", "radius", "weight"?, <params>}], "polylines": [{"points":
    /// [[x,y,z], ...], "closed"?, "radius", "weight"?, <params>}], "points": [{"p", "radius",
    /// "weight"?, "direction"?, <params>}], "triangles": [{"a", "b", "c", "radius", "weight"?,
    /// "direction"?, <params>}]}, at least one primitive; <params>: "amplitude", "frequency",
    /// "tilt", each a number or one per vertex. Unknown keys are errors naming them.
    static DirectionField fromSkeletonJson(const nlohmann::json& j);
    /// True when a primitive carries a parameter.
    bool hasParameters() const;
    /// Largest amplitude / frequency a primitive carries (0 when none).
    double maxAmplitude() const;
    double maxFrequency() const;
};

/// Near frame singularities (W ∥ n, umbilics): cancel the anisotropic noise (the paper's
/// choice), or fade into isotropic noise (its suggested fix). Auto: isotropic for curvature
/// frames (a sphere is umbilic everywhere) and skeleton frames (the paper's fix for where W and
/// ∇f are collinear, §5), cancel for an axis.
enum class Singular { Auto, Cancel, Isotropic };

struct GaborParams
{
    double amplitude = 0.0;      ///< A (m): largest surface displacement; 0 disables
    double frequency = 0.0;      ///< F0 (cycles per metre); 0 = 1/(10·A) (see resolved())
    double bandwidth = 0.0;      ///< a (1/m); 0 = F0 / 2
    double orientationDeg = 0.0; ///< ω: angle of the frequency direction from t towards b
    double impulses = 16.0;      ///< expected impulses per kernel ball
    bool isotropic = false;      ///< isotropic noise everywhere (no frames needed)
    double falloff = 0.0;        ///< R (m): the blob reach K(|p p_S|/R); 0 = 12·A (monotone)
    double tiltDeg = 0.0;        ///< α: projection direction tilted from the normal
    double tiltAzimuthDeg = 0.0; ///< θ: azimuth of the tilt in the frame, from t towards b
    Singular singular = Singular::Auto;
    uint64_t seed = 0;
};

/// The parameters that may vary in space (gabor §4, "Blending implicit surfaces carrying
/// details"): where the blend mask reads w ∈ [0, 1] each is (1 − w)·base + w·this, the field
/// contributions of the two parameter sets. Shape parameters (amplitudes, falloff, tilt) are
/// weighted at the evaluation point, noise parameters (frequency, orientation) at the
/// projected point p_S. One Gabor noise with interpolated parameters, not two noises mixed:
/// blends do not blur the details.
struct BlendParams
{
    double warpAmplitude = 0.0;
    double gaborAmplitude = 0.0;
    double frequency = 0.0;      ///< 0 = the base frequency
    double orientationDeg = 0.0;
    double falloff = 0.0;        ///< 0 = 12 × the blended amplitude
    double tiltDeg = 0.0, tiltAzimuthDeg = 0.0;
};

struct DetailParams
{
    ReliefParams warp;           ///< gradient warp (amplitude 0 disables)
    GaborParams gabor;           ///< Gabor details (amplitude 0 disables)
    DirectionField direction;
    uint64_t seed = 0;           ///< warp relief seed
    /// Optional spatial blend towards a second parameter set, weighted by a scalar grid
    /// (world-space trilinear samples clamped to [0, 1]; background = outside).
    std::shared_ptr<const BlendParams> blend;
    openvdb::FloatGrid::ConstPtr blendMask;
    /// @brief ValueError for unusable settings; frequencies above the Nyquist limit of
    /// @a voxelSize (F0 + 2a > 1/(2·voxel)) are refused with the limit in the message.
    void validate(double voxelSize) const;
    /// @brief From JSON keyed as the stage's table (detailSchema() in DetailStage.h, the CLI's
    /// names: warp-amplitude, gabor-frequency, direction-axis, ...); unknown keys and bad
    /// values are ValueErrors. The blend mask grid is set separately.
    static DetailParams fromJson(const nlohmann::json& j);
    /// Gabor ridges default to ten times as wide as they are high: F0 = 1/(10·A).
    static constexpr double kDefaultWavelengthPerAmplitude = 10.0;
    /// @brief A copy with defaults that depend on other parameters filled in (a Gabor
    /// frequency of 0 becomes 1/(10·A)); the bake entry points call it.
    DetailParams resolved() const;
    /// Largest warp / Gabor amplitude over the base and blend sets.
    double maxWarp() const;
    double maxGabor() const;
    /// Distance from the input surface within which the input must be exact: where the
    /// result's band can be (for levelSetField's widening).
    double reach(double halfWidthMetres) const;
};

/// @brief The input with the gradient warp, then the Gabor details, applied.
/// @param gradientStep  central-difference step for gradients (m; the input's voxel size)
/// @note With both amplitudes 0 the input itself is returned.
FieldPtr detailField(FieldPtr input, const DetailParams& p, double gradientStep);

/// @brief Detail a level-set grid and re-bake it as a narrow-band level set (renormalised):
/// the grid's band is first widened (widenBand) to params.reach(), the detail field
/// is baked over the input's active bounds grown by the amplitudes. With both amplitudes 0
/// the input's band values come back unchanged (trilinear samples at voxel centres).
/// @throw ValueError for a grid that is not a level set or unusable parameters.
/// @a widened, if given, receives the widened input (carryAttributes walks on it).
BakeResult detailLevelSet(openvdb::FloatGrid::ConstPtr grid, const DetailParams& p,
                          const BakeSettings& settings,
                          openvdb::util::NullInterrupter* interrupt = nullptr,
                          openvdb::FloatGrid::ConstPtr* widened = nullptr);

/// @brief Attribute grids (block_id, material, ...) of the input carried onto a detailed
/// level set: each active voxel of @a detailed takes the value of @a ids at the nearest voxel
/// of the input surface point it projects to (p - f(p)·∇f, iterated into the input's band).
/// Integer ids stay ids (no interpolation); the result has @a detailed's active topology.
openvdb::FloatGrid::Ptr carryAttribute(const openvdb::FloatGrid& input,
                                       const openvdb::FloatGrid& detailed,
                                       const openvdb::FloatGrid& ids);

/// @brief carryAttribute for several grids at once: the walk to the input surface is made
/// once per voxel and serves every grid (same values as one carryAttribute per grid). An
/// @a interrupt that fires leaves the grids incomplete: the caller checks it and stops.
std::vector<openvdb::FloatGrid::Ptr>
carryAttributes(const openvdb::FloatGrid& input, const openvdb::FloatGrid& detailed,
                const std::vector<const openvdb::FloatGrid*>& ids,
                openvdb::util::NullInterrupter* interrupt = nullptr);

} // namespace detail
} // namespace rockvdb
