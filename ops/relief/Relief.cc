// SPDX-License-Identifier: Apache-2.0
#include "Relief.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

namespace rockvdb {
namespace relief {

namespace {
int wrap(int i, int n) { return ((i % n) + n) % n; }
// The procedural relief's table texel: scale/64 (8 texels across the 4th octave's wavelength
// at the default scale).
double tableTexel(const ReliefParams& p) { return p.scale / 64.0; }
} // namespace

size_t tableTexels(const ReliefParams& p, float lo, float hi)
{
    if (!(p.amplitude > 0) || !p.image.empty()) return 0;
    const double span = double(hi - lo) + 2.0;
    const double n = std::ceil(span / tableTexel(p)) + 2;
    return n * n <= 16e6 ? size_t(n) * size_t(n) : 0;
}

Relief::Relief(const ReliefParams& p, uint64_t seed, float lo, float hi)
    : mAmp(float(p.amplitude))
{
    mFbm.frequency = 1.0 / p.scale;
    mFbm.octaves = p.octaves;
    mInvSum = float(1.0 / mFbm.amplitudeSum());
    mSeed = random::hash(seed, 0x72656c66 /*relf*/, 0);
    mScale = float(p.scale);
    if (mAmp <= 0) return;
    if (!p.image.empty()) {
        mImage = readGrayImage(p.image, "relief");
        if (mImage.width < 2 || mImage.height < 2) {
            fail<ValueError>("relief: image '", p.image, "' must be at least 2x2 pixels");
        }
        float a = std::numeric_limits<float>::infinity(), b = -a;
        for (float v : mImage.pixels) {
            if (!std::isfinite(v)) fail<ValueError>("relief: image '", p.image,
                                                    "' holds non-finite values");
            a = std::min(a, v);
            b = std::max(b, v);
        }
        mLo = a;
        mInvRange = b > a ? 1.0f / (b - a) : 0.0f;
        // Largest step between neighbouring texels (wrapping), for slopeBound().
        float step = 0;
        for (int j = 0; j < mImage.height; ++j)
            for (int i = 0; i < mImage.width; ++i) {
                const float v = mImage.at(i, j);
                step = std::max(step, std::abs(v - mImage.at((i + 1) % mImage.width, j)));
                step = std::max(step, std::abs(v - mImage.at(i, (j + 1) % mImage.height)));
            }
        mImageSlope = 2.0f * mAmp * step * mInvRange *
                      float(std::max(mImage.width, mImage.height)) / mScale;
        return;
    }
    // Procedural relief: tabulate the turbulence once (tableTexel) over the coordinate range.
    const double texel = tableTexel(p);
    if (const size_t texels = tableTexels(p, lo, hi)) {
        mTableN = int(std::lround(std::sqrt(double(texels))));
        mTableLo = lo - 1.0f;
        mTableTexel = float(texel);
        mTable.resize(size_t(mTableN) * size_t(mTableN));
        tbb::parallel_for(tbb::blocked_range<int>(0, mTableN), [&](const tbb::blocked_range<int>& r) {
            for (int j = r.begin(); j != r.end(); ++j)
                for (int i = 0; i < mTableN; ++i) {
                    mTable[size_t(j) * size_t(mTableN) + size_t(i)] =
                        direct(mTableLo + float(i) * mTableTexel, mTableLo + float(j) * mTableTexel);
                }
        });
    }
}

float Relief::image(float u, float v) const
{
    const float x = u / mScale * float(mImage.width), y = v / mScale * float(mImage.height);
    const float fx = std::floor(x), fy = std::floor(y);
    const int i0 = wrap(int(fx), mImage.width), j0 = wrap(int(fy), mImage.height);
    const int i1 = (i0 + 1) % mImage.width, j1 = (j0 + 1) % mImage.height;
    const float tx = x - fx, ty = y - fy;
    const float a = mImage.at(i0, j0) + (mImage.at(i1, j0) - mImage.at(i0, j0)) * tx;
    const float b = mImage.at(i0, j1) + (mImage.at(i1, j1) - mImage.at(i0, j1)) * tx;
    const float r = ((a + (b - a) * ty) - mLo) * mInvRange;
    return mInvRange > 0 ? mAmp * (1.0f - 2.0f * r) : 0.0f;
}

// Turbulence: creases (turbulence 0) carve grooves (d = +A, the surface moves inwards),
// high turbulence raises bumps.
float Relief::direct(float u, float v) const
{
    const float t = noise::turbulence2(mSeed, mFbm, u, v) * mInvSum;
    return mAmp * std::min(1.0f, std::max(-1.0f, 1.0f - 2.8f * t));
}

double Relief::slopeBound() const
{
    if (mAmp <= 0) return 0.0;
    if (mImage.width > 0) return mImageSlope;
    return double(mAmp) * 2.8 * noise::kGradientBound2 * mFbm.gradientSum() * double(mInvSum);
}

} // namespace relief
} // namespace rockvdb
