// SPDX-License-Identifier: Apache-2.0
// rockvdb — counter-based random numbers.
//
// Every random quantity in rockvdb is a pure function of (seed, stream, index): no generator
// state is shared or advanced, so results do not depend on thread count or evaluation order.
#pragma once

#include <cstdint>

namespace rockvdb {
namespace random {

/// @brief The splitmix64 finaliser: a bijective 64-bit mixer with full avalanche.
inline constexpr uint64_t mix64(uint64_t x)
{
    x ^= x >> 30; x *= 0xbf58476d1ce4e5b9ULL;
    x ^= x >> 27; x *= 0x94d049bb133111ebULL;
    x ^= x >> 31;
    return x;
}

/// @brief 64 random bits for (seed, stream, index).
inline constexpr uint64_t hash(uint64_t seed, uint64_t stream, uint64_t index)
{
    return mix64(mix64(mix64(seed + 0x9e3779b97f4a7c15ULL) ^ stream) + index);
}

/// @brief 64 random bits for a lattice point (i, j, k) of stream @a stream.
inline constexpr uint64_t hashCoord(uint64_t seed, uint64_t stream, int32_t i, int32_t j,
                                    int32_t k = 0)
{
    uint64_t h = mix64(seed + 0x9e3779b97f4a7c15ULL) ^ stream;
    h = mix64(h + uint64_t(uint32_t(i)));
    h = mix64(h + uint64_t(uint32_t(j)));
    return mix64(h + uint64_t(uint32_t(k)));
}

/// @brief Uniform double in [0, 1) from 53 random bits.
inline constexpr double toUnit(uint64_t bits) { return double(bits >> 11) * 0x1.0p-53; }

/// @brief Uniform double in [0, 1) for (seed, stream, index).
inline constexpr double uniform(uint64_t seed, uint64_t stream, uint64_t index)
{
    return toUnit(hash(seed, stream, index));
}

/// @brief Uniform double in [lo, hi) for (seed, stream, index).
inline constexpr double uniform(uint64_t seed, uint64_t stream, uint64_t index, double lo,
                                double hi)
{
    return lo + (hi - lo) * uniform(seed, stream, index);
}

} // namespace random
} // namespace rockvdb
