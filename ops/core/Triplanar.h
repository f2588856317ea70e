// SPDX-License-Identifier: Apache-2.0
// rockvdb — the triplanar blend with Lp weights: the blocks paper's gradient-based warp
// (implicit-blocks-rocky-scenery.txt §4.2, p = 1) and the arches paper's texture mapping of
// terrains of any geometry (arches-material-stacks-terrain.txt §6, p = 8).
#pragma once

#include <algorithm>
#include <cmath>

namespace rockvdb {

/// @brief Σ α_i v_i for a unit direction g (a gradient, a normal), α_i = |g·u_i|^p / Σ_j |g·u_j|^p,
/// v_i the value of the projection along axis u_i: @a vxy (along z), @a vxz (along y), @a vyz
/// (along x). p = 1: the blocks paper's |g·u_i| (so the warp moves the surface by at most its
/// amplitude); p = 8: the arches paper's sharper blend. (§6 writes α T(|x|, |y|) with α from
/// |x|: the weight of an axis must go with the projection along it, the plane of the other two,
/// or a wall facing x would show its top's texture; this pairs them so.)
inline float triplanar(float gx, float gy, float gz, float vxy, float vxz, float vyz, float p)
{
    float ax = std::abs(gx), ay = std::abs(gy), az = std::abs(gz);
    if (p == 8.0f) {
        // The default exponent by squaring (no pow call; the same value up to rounding).
        ax *= ax; ay *= ay; az *= az;
        ax *= ax; ay *= ay; az *= az;
        ax *= ax; ay *= ay; az *= az;
    } else if (p != 1.0f) {
        ax = std::pow(ax, p);
        ay = std::pow(ay, p);
        az = std::pow(az, p);
    }
    const float sum = std::max(ax + ay + az, 1e-12f);
    return (az * vxy + ay * vxz + ax * vyz) / sum;
}

} // namespace rockvdb
