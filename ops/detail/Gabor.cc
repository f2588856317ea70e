// SPDX-License-Identifier: Apache-2.0
#include "Gabor.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace rockvdb {
namespace detail {

namespace {
// exp(-π a² r²) = 5% at the truncation radius.
const double kTruncation = std::sqrt(-std::log(0.05) / M_PI);

// Knuth's Poisson sampler on counter-based uniforms (means up to ~61 for 256 impulses per
// kernel; the cap is far beyond any count with a real probability, it only bounds the loop).
int poisson(double mean, uint64_t seed, uint64_t cellHash)
{
    const double limit = std::exp(-mean);
    double prod = random::toUnit(random::mix64(cellHash ^ seed));
    int k = 0;
    while (prod > limit && k < 1024) {
        ++k;
        prod *= random::toUnit(random::mix64(cellHash + uint64_t(k) * 0x9e3779b97f4a7c15ULL));
    }
    return k;
}
} // namespace

GaborNoise::GaborNoise(double frequency, double bandwidth, double impulses, uint64_t seed)
    : mF(frequency), mA(bandwidth), mSeed(seed)
{
    mR = kTruncation / mA;
    // λ impulses per m³ such that a kernel ball holds `impulses` on average; cells of edge r.
    const double lambda = impulses / (4.0 / 3.0 * M_PI * mR * mR * mR);
    mMeanPerCell = lambda * mR * mR * mR;
    // Var n = λ E[w²] ∫ g² = λ/3 · ½ (2a²)^(-3/2) (1 + exp(-2π F0²/a²)) (untruncated kernel).
    mSigma = std::sqrt(lambda / 6.0 * std::pow(2.0 * mA * mA, -1.5) *
                       (1.0 + std::exp(-2.0 * M_PI * mF * mF / (mA * mA))));
}

void GaborNoise::impulses(const Vec3f& lo, const Vec3f& hi, std::vector<GaborImpulse>& out) const
{
    const double r = mR;
    int c0[3], c1[3];
    for (int a = 0; a < 3; ++a) {
        c0[a] = int(std::floor((double(lo[a]) - r) / r));
        c1[a] = int(std::floor((double(hi[a]) + r) / r));
    }
    for (int i = c0[0]; i <= c1[0]; ++i)
        for (int j = c0[1]; j <= c1[1]; ++j)
            for (int k = c0[2]; k <= c1[2]; ++k) {
                const uint64_t h = random::hashCoord(mSeed, 0x6761626f /*gabo*/, i, j, k);
                const int count = poisson(mMeanPerCell, mSeed, h);
                for (int m = 0; m < count; ++m) {
                    auto u = [&](int s) {
                        return random::toUnit(random::hash(h, uint64_t(m), uint64_t(s)));
                    };
                    GaborImpulse g;
                    g.x = float((i + u(0)) * r);
                    g.y = float((j + u(1)) * r);
                    g.z = float((k + u(2)) * r);
                    // Impulses farther than r from the box reach none of its points.
                    const float ex = std::max({lo[0] - g.x, g.x - hi[0], 0.0f});
                    const float ey = std::max({lo[1] - g.y, g.y - hi[1], 0.0f});
                    const float ez = std::max({lo[2] - g.z, g.z - hi[2], 0.0f});
                    if (double(ex * ex + ey * ey + ez * ez) >= r * r) continue;
                    g.w = float(2.0 * u(3) - 1.0);
                    // Uniform direction on the sphere (isotropic noise).
                    const double cz = 2.0 * u(4) - 1.0, phi = 2.0 * M_PI * u(5);
                    const double sz = std::sqrt(std::max(0.0, 1.0 - cz * cz));
                    g.ox = float(sz * std::cos(phi));
                    g.oy = float(sz * std::sin(phi));
                    g.oz = float(cz);
                    out.push_back(g);
                }
            }
}

namespace {

// exp(x) for x in [-8, 0] (the truncated Gaussian reaches -3): 2^(x·log2 e) with a degree-5
// polynomial for 2^f on [0, 1) and the integer part in the exponent bits; rel. error < 2e-7.
inline float fastExp(float x)
{
    x = std::max(x, -80.0f);
    const float t = x * 1.44269504f;
    // floor(t) without a libm call (SSE2 has no floor): round to nearest, step down if above.
    float fi = (t + 12582912.0f) - 12582912.0f;
    fi = fi > t ? fi - 1.0f : fi;
    const float f = t - fi;
    float p = 1.8775767e-3f;
    p = p * f + 8.9893397e-3f;
    p = p * f + 5.5826318e-2f;
    p = p * f + 2.4015361e-1f;
    p = p * f + 6.9315308e-1f;
    p = p * f + 9.9999994e-1f;
    int32_t bits;
    std::memcpy(&bits, &p, 4);
    bits += int32_t(uint32_t(int32_t(fi)) << 23); // (a negative exponent: shift it unsigned)
    std::memcpy(&p, &bits, 4);
    return p;
}

// cos(2π·u) for any u: reduce to r in [-1/2, 1/2], then an even polynomial in (2πr)²
// (Taylor to x^14 on [-π, π]); abs. error < 1e-6.
inline float cosTurns(float u)
{
    // u - round(u) with the 1.5·2^23 trick (exact for |u| < 2^22; SSE2 has no round).
    const float r = u - ((u + 12582912.0f) - 12582912.0f);
    const float x = r * 6.28318531f;
    const float z = x * x;
    float p = -1.1470745e-11f;
    p = p * z + 2.0876757e-9f;
    p = p * z - 2.7557319e-7f;
    p = p * z + 2.4801587e-5f;
    p = p * z - 1.3888889e-3f;
    p = p * z + 4.1666667e-2f;
    p = p * z - 0.5f;
    return p * z + 1.0f;
}

} // namespace

void GaborNoise::eval(const std::vector<GaborImpulse>& imp, int n, const float* x,
                      const float* y, const float* z, const float* ox, const float* oy,
                      const float* oz, const float* nx, const float* ny, const float* nz,
                      const float* iso, float* out) const
{
    for (int b = 0; b < n; b += kMaxBatch) {
        evalBlock(imp, std::min(n - b, kMaxBatch), x + b, y + b, z + b, ox + b, oy + b, oz + b,
                  nx + b, ny + b, nz + b, iso + b, out + b);
    }
}

void GaborNoise::evalBlock(const std::vector<GaborImpulse>& imp, int n, const float* x,
                           const float* y, const float* z, const float* ox, const float* oy,
                           const float* oz, const float* nx, const float* ny, const float* nz,
                           const float* iso, float* out) const
{
    const float r2 = float(mR * mR);
    const float env = float(-M_PI * mA * mA);
    const float f0 = float(mF); // cycles per metre: cos(2π f0 d·o) = cosTurns(f0 d·o)
    for (int i = 0; i < n; ++i) out[i] = 0.0f;
    bool anyIso = false;
    for (int i = 0; i < n; ++i) anyIso |= iso[i] > 0.0f;
    // Per impulse: d² (and d·o) at every point in one vectorised pass, the points within the
    // truncation radius gathered, the kernel (exp and cos) evaluated on those only in a
    // second vectorised pass, and added back. Kernels beyond the radius contribute exactly 0;
    // each point sums its impulses in the same order, with the same operations, as a loop
    // over points with a branch would (the values do not depend on the batch).
    alignas(64) float d2[kMaxBatch], dot[kMaxBatch], val[kMaxBatch];
    alignas(64) float cd2[kMaxBatch], cdot[kMaxBatch], cvi[kMaxBatch];
    alignas(64) int idx[kMaxBatch];
    for (const GaborImpulse& g : imp) {
        const float gx = g.x, gy = g.y, gz = g.z, gw = g.w;
        for (int i = 0; i < n; ++i) {
            const float dx = x[i] - gx, dy = y[i] - gy, dz = z[i] - gz;
            d2[i] = dx * dx + dy * dy + dz * dz;
            dot[i] = dx * ox[i] + dy * oy[i] + dz * oz[i];
        }
        int m = 0;
        for (int i = 0; i < n; ++i) {
            idx[m] = i;
            m += d2[i] < r2 ? 1 : 0;
        }
        if (m == 0) continue;
        for (int k = 0; k < m; ++k) {
            cd2[k] = d2[idx[k]];
            cdot[k] = dot[idx[k]];
        }
        if (!anyIso) {
            for (int k = 0; k < m; ++k) {
                val[k] = gw * fastExp(env * cd2[k]) * cosTurns(f0 * cdot[k]);
            }
        } else {
            for (int k = 0; k < m; ++k) {
                const int i = idx[k];
                const float dx = x[i] - gx, dy = y[i] - gy, dz = z[i] - gz;
                // The impulse's direction projected on the tangent plane at the point.
                const float on = g.ox * nx[i] + g.oy * ny[i] + g.oz * nz[i];
                const float px = g.ox - on * nx[i], py = g.oy - on * ny[i], pz = g.oz - on * nz[i];
                cvi[k] = f0 * (dx * px + dy * py + dz * pz);
            }
            for (int k = 0; k < m; ++k) {
                const int i = idx[k];
                const float vi = cosTurns(cvi[k]);
                const float va = iso[i] < 1.0f ? cosTurns(f0 * cdot[k]) : vi;
                val[k] = gw * fastExp(env * cd2[k]) * (va + iso[i] * (vi - va));
            }
        }
        for (int k = 0; k < m; ++k) out[idx[k]] += val[k];
    }
}

} // namespace detail
} // namespace rockvdb
