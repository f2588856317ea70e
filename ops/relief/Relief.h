// SPDX-License-Identifier: Apache-2.0
// rockvdb — the relief d : R² → [-A, A] and the triplanar weights of the gradient-based warp
// (implicit-blocks-rocky-scenery.txt §4.2; sharper Lp weights from
// arches-material-stacks-terrain.txt §6).
#pragma once

#include <rockvdb/core/Image.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Triplanar.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace rockvdb {
namespace relief {

/// Relief d of the gradient-based warp (§4.2): procedural turbulence or a tiled image. The
/// initial values are neutral (no warp); each stage's table (blocks, detail) holds the
/// defaults its users get.
struct ReliefParams
{
    double amplitude = 0.0;  ///< metres; the surface moves by at most this (0 disables)
    double scale = 1.5;      ///< metres: noise wavelength, or world size of one image tile
    int octaves = 4;         ///< turbulence octaves
    std::string image;       ///< EXR / 16-bit PNG relief (empty: procedural turbulence)
    double sharpness = 1.0;  ///< exponent p of the projection weights |g·u_i|^p / Σ|g·u_j|^p
};

/// d(u, v) in [-A, A] (positive = the surface moves inwards: a groove).
///  - Image: tiled bilinear lookup, one image tile per @c scale metres; bright = bump.
///  - Turbulence: creases carve grooves and high turbulence raises bumps. It is tabulated
///    once (texel = scale/64) over the coordinate range [lo, hi] when that fits in 16 M
///    texels, so the three projections of a point cost three bilinear lookups.
/// @brief Texels of the procedural relief's table over [lo, hi] (texel scale/64, when that
/// fits in 16 M texels; 0 when it is not tabulated: no amplitude, an image, or too large) —
/// its memory is 4 bytes each.
size_t tableTexels(const ReliefParams& p, float lo, float hi);

class Relief
{
public:
    /// @throw ValueError / IoError for an unreadable, tiny or non-finite image.
    Relief(const ReliefParams& p, uint64_t seed, float lo, float hi);

    float amplitude() const { return mAmp; }

    float operator()(float u, float v) const
    {
        if (mImage.width > 0) return image(u, v);
        if (mTableN > 0) {
            const float top = float(mTableN - 1) - 1e-3f;
            const float x = std::min(std::max((u - mTableLo) / mTableTexel, 0.0f), top);
            const float y = std::min(std::max((v - mTableLo) / mTableTexel, 0.0f), top);
            const int i = int(x), j = int(y);
            const float tx = x - float(i), ty = y - float(j);
            const float* row = mTable.data() + size_t(j) * size_t(mTableN) + size_t(i);
            const float a = row[0] + (row[1] - row[0]) * tx;
            const float b = row[mTableN] + (row[mTableN + 1] - row[mTableN]) * tx;
            return a + (b - a) * ty;
        }
        return direct(u, v);
    }

    /// Bound of |∇d| (per metre), for Lipschitz bounds of warped fields.
    double slopeBound() const;

private:
    float image(float u, float v) const;
    float direct(float u, float v) const;

    float mAmp;
    noise::Fbm mFbm;
    float mInvSum = 1, mScale = 1;
    uint64_t mSeed = 0;
    GrayImage mImage;
    float mLo = 0, mInvRange = 0, mImageSlope = 0;
    int mTableN = 0;
    float mTableLo = 0, mTableTexel = 1;
    std::vector<float> mTable;
};

/// The triplanar displacement magnitude Σ α_i d(γ_i(p)) for a unit gradient g (dxy, dxz, dyz:
/// d at the projections on the xy, xz and yz planes; core/Triplanar.h).
using rockvdb::triplanar;

} // namespace relief
} // namespace rockvdb
