// SPDX-License-Identifier: Apache-2.0
// rockvdb — swept volumes for cracks, ravines and tunnels ("Arches: a Framework for Modeling
// Complex Terrains", §4.2, after [DGA05]): a graph G whose nodes carry profile curves
// (closed piecewise cubic curves, non-convex allowed) interpolated along its arcs and oriented
// by a normal (the terrain's, for cracks; up, for tunnels) and the arc's tangent; the volume is
// the union of the prisms between consecutive cross-sections.
#pragma once

#include <rockvdb/core/Field.h>

#include <openvdb/math/Vec2.h>

#include <functional>
#include <utility>
#include <vector>

namespace rockvdb {
namespace arches {

using Vec2d = openvdb::math::Vec2<double>;

/// @brief A closed curve through @a control (u, v) points: a closed Catmull-Rom spline (or the
/// polygon itself when @a spline is false), resampled to @a count points evenly spread along
/// its length, starting at the first control point.
std::vector<Vec2d> sampleProfile(const std::vector<Vec2d>& control, bool spline, int count);

struct SweepSpec
{
    std::vector<Vec3d> nodes;                 ///< the graph's nodes (m)
    std::vector<std::pair<int, int>> arcs;    ///< node index pairs
    std::vector<std::vector<Vec2d>> profiles; ///< sampled profiles (sampleProfile), the same count each
    std::vector<int> nodeProfile;             ///< per node: its profile
    double step = 0.5;                        ///< spacing of cross-sections along arcs (m)
    /// The cross-section's "v" axis at a point of an arc (unit; made orthogonal to the
    /// tangent): the terrain's outward normal for cracks; unset = world up (tunnels).
    std::function<Vec3d(const Vec3d&)> normal;
    /// Where a cross-section's centre goes (cracks: projected on the terrain); unset = as is.
    std::function<Vec3d(const Vec3d&)> place;
};

/// A swept volume: prisms between consecutive cross-sections of every arc. inside(p) > 0 inside
/// (roughly the distance to the boundary, m), <= 0 outside. @throw ValueError (from the
/// constructor) when the arcs' length over the step asks for more than kMaxPrisms prisms.
class SweepVolume
{
public:
    explicit SweepVolume(const SweepSpec& spec);

    /// @brief Over @a prisms, those whose box holds the vertical line through p's (x, y)
    /// (candidates(x, y)): one stack axis's heights evaluate against the same few.
    double inside(const Vec3d& p, const std::vector<uint32_t>& prisms) const;
    std::vector<uint32_t> candidates(double x, double y) const;
    /// The prisms' z extent over the vertical line through (x, y) (empty when none).
    std::pair<double, double> zRange(const std::vector<uint32_t>& prisms) const;
    BBoxd bounds() const { return mBounds; }

    /// Most prisms a sweep may hold (~0.5 GB): more is a step far too small for the graph.
    static constexpr size_t kMaxPrisms = 2'000'000;

private:
    struct Section
    {
        Vec3d origin, t, n, b; // centre, tangent, v axis, u axis
        int profile = 0;
    };
    struct Prism
    {
        Section a, b;
        double lo = 0, hi = 1; // the axial range kept (beyond [0, 1] where a neighbour continues)
        double wa = 0, wb = 1; // where its ends sit along the arc: the blend of the two profiles
        BBoxd box;
    };
    double prismInside(const Prism& q, const Vec3d& p) const;

    std::vector<std::vector<Vec2d>> mProfiles;
    std::vector<Prism> mPrisms;
    BBoxd mBounds;
};

} // namespace arches
} // namespace rockvdb
