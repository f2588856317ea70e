// SPDX-License-Identifier: Apache-2.0
// rockvdb — the Field concept: a thread-safe p ↦ signed distance.
//
// A Field is a pure function of world position (metres, z up) returning a signed distance,
// negative inside (OpenVDB convention), plus the two facts the sparse baker needs:
//   bounds()     a world box containing the inside region {f <= 0} (may be infinite);
//   modulus(r)   ω(r) with |f(q)| >= |f(p)| - ω(|p - q|) wherever |f(q)| lies in the band.
//                Every L-Lipschitz field satisfies it with ω(r) = L·r (the default, from
//                lipschitz()); so does a field that is an exact distance near its surface and
//                a lower bound of the distance elsewhere. Warps by a displacement of at most
//                A get ω(r) = r + 2A instead of a large slope (see Combinators.h).
// exact() says whether values in the band are true Euclidean distances; bakes of non-exact
// fields (warps, smooth blends, non-rigid transforms) should be renormalised (see Bake.h).
//
// Fields are evaluated in batches of points (structure of arrays, at most kMaxBatch points)
// so that one virtual call serves a whole leaf and primitive loops vectorise.
#pragma once

#include <openvdb/math/BBox.h>
#include <openvdb/math/Vec3.h>

#include <limits>
#include <memory>
#include <string>

namespace rockvdb {

using Vec3f = openvdb::math::Vec3<float>;
using Vec3d = openvdb::math::Vec3<double>;
using BBoxd = openvdb::math::BBox<Vec3d>;

/// Largest batch a Field is ever asked to evaluate (a padded 10³ leaf fits).
constexpr int kMaxBatch = 1024;

/// Attribute id of points not claimed by any tagged sub-field.
constexpr float kNoId = -1.0f;

/// @brief Points in structure-of-arrays layout; @c n <= kMaxBatch.
///
/// Culling hints: every point lies within @c radius of @c center, and values whose magnitude
/// is at least @c band are all equivalent to the caller (the baker clamps them to the
/// background). Combinators use them to skip operands that cannot matter anywhere in the
/// batch; band = +inf (the default) disables culling and gives exact values everywhere.
/// @c reach (m) is the same fact as a distance: fields that are exact only near their
/// surface (heightfields) must be exact within reach and may return a lower bound >= reach
/// beyond it.
struct Batch
{
    const float* x;
    const float* y;
    const float* z;
    int n;
    Vec3f center = Vec3f(0.0f);
    float radius = std::numeric_limits<float>::infinity();
    float band = std::numeric_limits<float>::infinity();
    float reach = std::numeric_limits<float>::infinity();
};

/// @brief A fixed-capacity batch that owns its coordinates.
struct BatchBuffer
{
    alignas(64) float x[kMaxBatch];
    alignas(64) float y[kMaxBatch];
    alignas(64) float z[kMaxBatch];
    int n = 0;
    Vec3f center = Vec3f(0.0f);
    float radius = std::numeric_limits<float>::infinity();
    float band = std::numeric_limits<float>::infinity();
    float reach = std::numeric_limits<float>::infinity();
    Batch view() const { return {x, y, z, n, center, radius, band, reach}; }
};

/// @brief A box so large it stands for "unbounded" (half-spaces, terrains without floor).
inline BBoxd infiniteBounds()
{
    const double big = std::numeric_limits<double>::max() / 4;
    return BBoxd(Vec3d(-big), Vec3d(big));
}

/// @brief True when every coordinate of @a b is finite and below 1e15 m.
bool isBounded(const BBoxd& b);

class Field
{
public:
    using Ptr = std::shared_ptr<const Field>;

    virtual ~Field() = default;

    /// @brief out[i] = f(p_i) for the @c b.n points of @a b. Thread-safe.
    virtual void evalBatch(const Batch& b, float* out) const = 0;

    /// @brief As evalBatch, and id[i] = the id of the tagged sub-field that determines
    /// f(p_i) (kNoId when none). The default fills kNoId.
    virtual void evalIdBatch(const Batch& b, float* out, float* id) const;

    /// @brief World box containing {f <= 0}; infiniteBounds() when unbounded.
    virtual BBoxd bounds() const = 0;

    /// @brief Lipschitz-style slope (see file comment). >= 1 for distances.
    virtual double lipschitz() const { return 1.0; }

    /// @brief Modulus of continuity ω(r) used for culling (see file comment); monotone in
    /// r. The default is lipschitz()·r.
    virtual double modulus(double r) const { return lipschitz() * r; }

    /// @brief Gradient of f at the points of @a b (not normalised). The default takes central
    /// differences with step @a h (six batch evaluations); fields that know better (a grid's
    /// precomputed gradient) override it.
    virtual void gradientBatch(const Batch& b, float h, float* gx, float* gy, float* gz) const;

    /// @brief Build whatever gradientBatch() reads (a grid's gradient grid), with all
    /// threads, before a bake evaluates the field; without it the first call builds it.
    virtual void prepareGradient() const {}

    /// @brief True when f is a Euclidean distance within the narrow band.
    virtual bool exact() const { return true; }

    /// @brief Single-point convenience (slow path: one batch of one).
    float eval(const Vec3d& p) const;
    float evalId(const Vec3d& p, float* id) const;
};

using FieldPtr = Field::Ptr;

} // namespace rockvdb
