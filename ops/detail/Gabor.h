// SPDX-License-Identifier: Apache-2.0
// rockvdb — surface Gabor noise (gabor-details-implicit-surfaces.txt §2–§3, after Lagae et
// al. 2009): n(x) = Σ_i w_i g(x - x_i), g(d) = exp(-π a² |d|²) cos(2π F0 d·o), impulses x_i
// Poisson-distributed per cell with uniform weights w_i ∈ [-1, 1], kernels truncated at the
// radius where the Gaussian falls to 5%. The frequency direction o lies in the surface's
// tangent plane (anisotropic: o = cos ω t + sin ω b in the local frame (n, t, b)); isotropic
// noise projects a random direction per impulse onto the tangent plane instead, which needs
// no frame. Impulses are a pure function of (seed, cell): same noise for any thread count.
#pragma once

#include <rockvdb/core/Field.h>

#include <cstdint>
#include <vector>

namespace rockvdb {
namespace detail {

struct GaborImpulse
{
    float x, y, z, w;    ///< position and weight
    float ox, oy, oz;    ///< random unit direction (isotropic noise)
};

class GaborNoise
{
public:
    /// @param frequency  F0 (cycles per metre), > 0
    /// @param bandwidth  a (1/m), > 0: kernel radius 0.98/a
    /// @param impulses   expected impulses per kernel ball, > 0
    GaborNoise(double frequency, double bandwidth, double impulses, uint64_t seed);

    double radius() const { return mR; }
    double frequency() const { return mF; }
    /// Standard deviation of n (anisotropic and isotropic alike, to first order).
    double sigma() const { return mSigma; }

    /// @brief Append the impulses of every cell within radius() of the box [lo, hi].
    void impulses(const Vec3f& lo, const Vec3f& hi, std::vector<GaborImpulse>& out) const;

    /// @brief Accumulate n at @a n points (x, y, z) with per-point frequency directions
    /// (ox, oy, oz) (anisotropic; a zero direction gives the envelope's low-pass noise) and
    /// normals (nx, ny, nz) (isotropic: the impulse direction projected on the tangent
    /// plane); @a iso[i] in [0, 1] blends the two (0 = anisotropic only).
    void eval(const std::vector<GaborImpulse>& imp, int n, const float* x, const float* y,
              const float* z, const float* ox, const float* oy, const float* oz,
              const float* nx, const float* ny, const float* nz, const float* iso,
              float* out) const;

private:
    void evalBlock(const std::vector<GaborImpulse>& imp, int n, const float* x, const float* y,
                   const float* z, const float* ox, const float* oy, const float* oz,
                   const float* nx, const float* ny, const float* nz, const float* iso,
                   float* out) const; // n <= kMaxBatch

    double mF, mA, mR, mMeanPerCell, mSigma;
    uint64_t mSeed;
};

} // namespace detail
} // namespace rockvdb
