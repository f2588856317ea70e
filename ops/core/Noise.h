// SPDX-License-Identifier: Apache-2.0
// rockvdb — deterministic gradient noise, fBm and turbulence in 2D and 3D.
//
// Lattice gradients are a counter-based hash of (seed, octave, lattice point), so noise is a
// pure function of its arguments. The quintic-fade gradient noise below has analytic bounds
// used for honest Lipschitz constants:
//   |n| <= 2 (each corner term |g·(p - c)| <= 2 and the fade weights sum to 1);
//   |∂n/∂x_i| <= 1 + fade'max · 4 = 8.5  (fade'max = 15/8), so |∇n| <= 8.5·√dim.
#pragma once

#include <cstdint>

namespace rockvdb {
namespace noise {

constexpr double kValueBound = 2.0;
constexpr double kGradientBound3 = 14.73; ///< 8.5·√3
constexpr double kGradientBound2 = 12.03; ///< 8.5·√2

/// @brief Gradient noise at p (lattice spacing 1), in [-2, 2], 0 at lattice points.
float gradient3(uint64_t seed, float x, float y, float z);
float gradient2(uint64_t seed, float x, float y);

/// @brief Fractal sum settings: Σ_o gain^o · n(p · frequency · lacunarity^o).
struct Fbm
{
    double frequency = 1.0; ///< base frequency (1/m)
    int octaves = 5;
    double lacunarity = 2.0;
    double gain = 0.5;

    /// @brief Σ_o gain^o (the factor on kValueBound).
    double amplitudeSum() const;
    /// @brief Σ_o gain^o · frequency · lacunarity^o (the factor on the gradient bound).
    double gradientSum() const;
    /// @brief ValueError naming @a op unless the settings are usable.
    void validate(const char* op) const;
};

float fbm3(uint64_t seed, const Fbm& s, float x, float y, float z);
float fbm2(uint64_t seed, const Fbm& s, float x, float y);
/// @brief Turbulence: Σ_o gain^o · |n(...)| (non-negative, creased).
float turbulence3(uint64_t seed, const Fbm& s, float x, float y, float z);
float turbulence2(uint64_t seed, const Fbm& s, float x, float y);

} // namespace noise
} // namespace rockvdb
