// SPDX-License-Identifier: Apache-2.0
// rockvdb — combinators over fields: CSG (hard and smooth), affine transforms, domain warps
// and id tags for attribute grids.
#pragma once

#include <rockvdb/core/Field.h>

#include <openvdb/math/Mat4.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace rockvdb {

/// @name The polynomial smooth operator of implicit-blocks-rocky-scenery §4.2
/// Paper: k(a, b) = max(1 - |a - b| / R, 0) and a blend term R·k³/6. The paper writes its
/// fields positive inside; translated to our negative-inside convention the smooth
/// intersection is max(a, b) + R·k³/6 (material removed along convex edges: the rounded
/// edges of its Fig. 8) and the smooth union is min(a, b) - R·k³/6 (a fillet is added).
/// With R = 0 both are the hard operators.
///
/// SmoothBlend holds one radius with 1/R and R/6 computed once, so a loop folding many
/// values with one radius (the block tiles' hull planes) inlines and vectorises it; the
/// per-call functions below are the same arithmetic.
/// @{
struct SmoothBlend
{
    float invR = 0.0f, r6 = 0.0f;

    explicit SmoothBlend(float radius)
        : invR(radius > 0.0f ? 1.0f / radius : 0.0f), r6(radius > 0.0f ? radius / 6.0f : 0.0f) {}

    /// k(a, b) = max(1 - |a - b| / R, 0) (0 for R = 0).
    float k(float a, float b) const { return std::max(1.0f - std::abs(a - b) * invR, 0.0f); }
    /// R·k³/6: what the smooth operators add to the hard ones.
    float term(float a, float b) const
    {
        const float kk = k(a, b);
        return r6 * kk * kk * kk;
    }
    float intersection(float a, float b) const { return std::max(a, b) + term(a, b); }
    float unite(float a, float b) const { return std::min(a, b) - term(a, b); }
    float difference(float a, float b) const { return intersection(a, -b); }
};

inline float smoothBlendTerm(float a, float b, float radius)
{
    if (!(radius > 0.0f)) return 0.0f;
    return SmoothBlend(radius).term(a, b);
}
inline float smoothIntersection(float a, float b, float radius)
{
    return std::max(a, b) + smoothBlendTerm(a, b, radius);
}
inline float smoothUnion(float a, float b, float radius)
{
    return std::min(a, b) - smoothBlendTerm(a, b, radius);
}
inline float smoothDifference(float a, float b, float radius)
{
    return smoothIntersection(a, -b, radius);
}
/// @}

enum class CsgOp { Union, Intersection, Difference };

/// @brief Parse "union" / "intersection" / "difference" (ValueError otherwise).
CsgOp csgOpFromString(const std::string& name);
const char* csgOpName(CsgOp op);

/// @brief Fold @a op over @a children left to right (smooth operators are not associative:
/// ((c0 op c1) op c2) ...). Difference subtracts every later child from the first.
/// @param smoothRadius  R of the smooth operator (m); 0 gives the hard operator.
/// @note Ids (evalIdBatch) come from the child that dominates each point; for a difference
/// they always come from the first child (the material being carved).
FieldPtr csg(CsgOp op, std::vector<FieldPtr> children, double smoothRadius = 0.0);

inline FieldPtr unite(FieldPtr a, FieldPtr b, double r = 0.0)
{
    return csg(CsgOp::Union, {std::move(a), std::move(b)}, r);
}
inline FieldPtr intersect(FieldPtr a, FieldPtr b, double r = 0.0)
{
    return csg(CsgOp::Intersection, {std::move(a), std::move(b)}, r);
}
inline FieldPtr subtract(FieldPtr a, FieldPtr b, double r = 0.0)
{
    return csg(CsgOp::Difference, {std::move(a), std::move(b)}, r);
}

/// @brief Place a field with an affine local-to-world matrix (OpenVDB row-vector convention,
/// p_world = p_local * M). Values are scaled by the smallest singular value of M so they stay
/// a lower bound of the world distance (exact for rigid motions and uniform scales), which
/// keeps the Lipschitz bound of the child.
FieldPtr transform(FieldPtr child, const openvdb::math::Mat4d& localToWorld);

/// @brief Local-to-world matrix: scale, then rotate (XYZ Euler angles, degrees), then
/// translate.
openvdb::math::Mat4d makeTransform(const Vec3d& translate, const Vec3d& rotateDegrees,
                                   const Vec3d& scale);

/// @brief A displacement field δ for domain warps p ↦ p + δ(p).
class Displacement
{
public:
    using Ptr = std::shared_ptr<const Displacement>;
    virtual ~Displacement() = default;
    /// @brief d{x,y,z}[i] = δ(p_i).
    virtual void displace(const Batch& b, float* dx, float* dy, float* dz) const = 0;
    /// @brief An upper bound of |δ(p)| over all p (m).
    virtual double maxMagnitude() const = 0;
    /// @brief An upper bound of the operator norm of the Jacobian of δ.
    virtual double lipschitz() const = 0;
};

/// @brief Domain warp f(p + δ(p)). Lipschitz bound L_f·(1 + L_δ); bounds grow by max|δ|.
/// Not exact: bake with renormalisation.
FieldPtr warp(FieldPtr child, Displacement::Ptr delta);

/// @brief Vector fBm displacement: each component an independent 3D gradient-noise fBm.
/// @param amplitude   scale of the displacement (m); the bound max|δ| is derived from it
/// @param frequency   base frequency (1/m)
/// @param octaves     number of octaves, >= 1
/// @param seed        noise seed
Displacement::Ptr noiseDisplacement(double amplitude, double frequency, int octaves,
                                    uint64_t seed, double lacunarity = 2.0, double gain = 0.5);

/// @brief Tag a field: evalIdBatch reports @a id wherever this sub-field decides the value.
/// @param id  integer-valued id, exactly representable (|id| < 2^24)
FieldPtr tag(FieldPtr child, float id);

} // namespace rockvdb
