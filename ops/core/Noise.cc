// SPDX-License-Identifier: Apache-2.0
#include "Noise.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>

#include <cmath>

namespace rockvdb {
namespace noise {

namespace {

inline float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
inline float lerp(float a, float b, float t) { return a + t * (b - a); }

// Perlin's 12 cube-edge directions, padded to 16 so a 4-bit hash picks one.
inline float grad3(uint64_t h, float x, float y, float z)
{
    switch (h & 15) {
    case 0: return x + y;   case 1: return -x + y;  case 2: return x - y;   case 3: return -x - y;
    case 4: return x + z;   case 5: return -x + z;  case 6: return x - z;   case 7: return -x - z;
    case 8: return y + z;   case 9: return -y + z;  case 10: return y - z;  case 11: return -y - z;
    case 12: return x + y;  case 13: return -y + z; case 14: return -x + y; default: return -y - z;
    }
}

inline float grad2(uint64_t h, float x, float y)
{
    switch (h & 7) {
    case 0: return x + y;  case 1: return -x + y; case 2: return x - y; case 3: return -x - y;
    case 4: return x;      case 5: return -x;     case 6: return y;     default: return -y;
    }
}

// Lattice hash: coordinates folded with large odd constants, then murmur3's 32-bit
// finaliser. One mix per corner (the seed is mixed once per call by the caller).
inline uint32_t fmix32(uint32_t h)
{
    h ^= h >> 16; h *= 0x85ebca6bu;
    h ^= h >> 13; h *= 0xc2b2ae35u;
    h ^= h >> 16;
    return h;
}
inline uint32_t latticeHash(uint32_t s, uint32_t i, uint32_t j, uint32_t k)
{
    return fmix32(s ^ (i * 0x8da6b343u) ^ (j * 0xd8163841u) ^ (k * 0xcb1ab31fu));
}

// The lattice cell of a floored coordinate as 32 bits: int32_t(f) wherever that conversion is
// defined (|f| < 2^31: every coordinate a bake reaches), wrapped modulo 2^32 beyond, so that
// a huge finite coordinate (a 4e122 m cell size fuzz_json found) is no undefined conversion.
// Corners add in unsigned arithmetic (i + 1 at 2^31 - 1 would overflow an int).
inline uint32_t cell(float f)
{
    if (std::fabs(f) < 2147483648.0f) return uint32_t(int32_t(f));
    if (!std::isfinite(f)) return 0; // (the noise is NaN there: x - floor(x) is)
    return uint32_t(int64_t(std::fmod(double(f), 4294967296.0)));
}

inline uint64_t octaveSeed(uint64_t seed, int octave)
{
    return random::hash(seed, 0x6e6f697365ULL /* "noise" */, uint64_t(octave));
}

} // namespace

float gradient3(uint64_t seed, float x, float y, float z)
{
    const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
    const uint32_t i = cell(fx), j = cell(fy), k = cell(fz);
    x -= fx; y -= fy; z -= fz;
    const float u = fade(x), v = fade(y), w = fade(z);
    const uint32_t s = uint32_t(random::mix64(seed ^ 0x3ULL));
    auto h = [&](int di, int dj, int dk) { return latticeHash(s, i + uint32_t(di), j + uint32_t(dj), k + uint32_t(dk)) >> 28; };
    const float n000 = grad3(h(0, 0, 0), x, y, z);
    const float n100 = grad3(h(1, 0, 0), x - 1, y, z);
    const float n010 = grad3(h(0, 1, 0), x, y - 1, z);
    const float n110 = grad3(h(1, 1, 0), x - 1, y - 1, z);
    const float n001 = grad3(h(0, 0, 1), x, y, z - 1);
    const float n101 = grad3(h(1, 0, 1), x - 1, y, z - 1);
    const float n011 = grad3(h(0, 1, 1), x, y - 1, z - 1);
    const float n111 = grad3(h(1, 1, 1), x - 1, y - 1, z - 1);
    return lerp(lerp(lerp(n000, n100, u), lerp(n010, n110, u), v),
                lerp(lerp(n001, n101, u), lerp(n011, n111, u), v), w);
}

float gradient2(uint64_t seed, float x, float y)
{
    const float fx = std::floor(x), fy = std::floor(y);
    const uint32_t i = cell(fx), j = cell(fy);
    x -= fx; y -= fy;
    const float u = fade(x), v = fade(y);
    const uint32_t s = uint32_t(random::mix64(seed ^ 0x2ULL));
    auto h = [&](int di, int dj) { return latticeHash(s, i + uint32_t(di), j + uint32_t(dj), 0) >> 29; };
    const float n00 = grad2(h(0, 0), x, y);
    const float n10 = grad2(h(1, 0), x - 1, y);
    const float n01 = grad2(h(0, 1), x, y - 1);
    const float n11 = grad2(h(1, 1), x - 1, y - 1);
    return lerp(lerp(n00, n10, u), lerp(n01, n11, u), v);
}

double Fbm::amplitudeSum() const
{
    double s = 0, a = 1;
    for (int o = 0; o < octaves; ++o, a *= gain) s += a;
    return s;
}

double Fbm::gradientSum() const
{
    double s = 0, a = 1, f = frequency;
    for (int o = 0; o < octaves; ++o, a *= gain, f *= lacunarity) s += a * f;
    return s;
}

void Fbm::validate(const char* op) const
{
    require(std::isfinite(frequency) && frequency > 0, op, "noise frequency", "> 0", frequency);
    require(octaves >= 1 && octaves <= 24, op, "noise octaves", "in [1, 24]", octaves);
    require(std::isfinite(lacunarity) && lacunarity >= 1, op, "noise lacunarity", ">= 1",
            lacunarity);
    require(std::isfinite(gain) && gain > 0 && gain <= 1, op, "noise gain", "in (0, 1]", gain);
}

namespace {
template<bool Turbulence, typename NoiseFn>
float fractal(const Fbm& s, NoiseFn&& fn)
{
    float sum = 0, amp = 1, f = float(s.frequency);
    for (int o = 0; o < s.octaves; ++o) {
        const float n = fn(o, f);
        sum += amp * (Turbulence ? std::abs(n) : n);
        amp *= float(s.gain);
        f *= float(s.lacunarity);
    }
    return sum;
}
} // namespace

float fbm3(uint64_t seed, const Fbm& s, float x, float y, float z)
{
    return fractal<false>(s, [&](int o, float f) {
        return gradient3(octaveSeed(seed, o), x * f, y * f, z * f);
    });
}

float turbulence3(uint64_t seed, const Fbm& s, float x, float y, float z)
{
    return fractal<true>(s, [&](int o, float f) {
        return gradient3(octaveSeed(seed, o), x * f, y * f, z * f);
    });
}

float fbm2(uint64_t seed, const Fbm& s, float x, float y)
{
    return fractal<false>(s, [&](int o, float f) {
        return gradient2(octaveSeed(seed, o), x * f, y * f);
    });
}

float turbulence2(uint64_t seed, const Fbm& s, float x, float y)
{
    return fractal<true>(s, [&](int o, float f) {
        return gradient2(octaveSeed(seed, o), x * f, y * f);
    });
}

} // namespace noise
} // namespace rockvdb
