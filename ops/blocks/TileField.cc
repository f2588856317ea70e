// SPDX-License-Identifier: Apache-2.0
// The block fields b_i = c_i ∘ ω⁻¹ (§4.2) and the tile field (their union, culled by cells).
#include <rockvdb/blocks/BlockTile.h>

#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridUtil.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/relief/Relief.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <climits>
#include <mutex>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>

namespace rockvdb {
namespace blocks {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();


float coordinateLow(const BlockTile& t)
{
    float lo = 0;
    for (const auto& b : t.blocks) for (float v : b.boundsMin) lo = std::min(lo, v);
    return lo - float(t.params.relief.amplitude);
}

float coordinateHigh(const BlockTile& t)
{
    float hi = float(t.size());
    for (const auto& b : t.blocks) for (float v : b.boundsMax) hi = std::max(hi, v);
    return hi + float(t.params.relief.amplitude);
}

// ---- one block ----------------------------------------------------------------------------

struct PlaneSoA
{
    std::vector<float> nx, ny, nz, d;
};

// Exact culling of the fold: plane k changes nothing where h_k <= f_{k-1} - R, and
// f_{k-1} >= max_{m<k} h_m. Over a batch (centre c, radius ρ) plane k is skipped when
// h_k(c) + ρ <= max_{m<k} h_m(c) - ρ - R. Value and gradient are then bitwise those of the
// full fold (a skipped step is the identity), whatever the batch.
void activePlanes(const PlaneSoA& P, const Vec3f& c, float rho, float R, std::vector<int>& out)
{
    out.clear();
    float run = -kInf;
    for (size_t k = 0; k < P.nx.size(); ++k) {
        const float v = P.nx[k] * c[0] + P.ny[k] * c[1] + P.nz[k] * c[2] - P.d[k];
        if (k == 0 || !(v + rho <= run - rho - R)) out.push_back(int(k));
        run = std::max(run, v);
    }
}

float maxPlane(const PlaneSoA& P, const Vec3f& c)
{
    float m = -kInf;
    for (size_t k = 0; k < P.nx.size(); ++k) {
        m = std::max(m, P.nx[k] * c[0] + P.ny[k] * c[1] + P.nz[k] * c[2] - P.d[k]);
    }
    return m;
}

// f = h_0 ∩̃ h_1 ∩̃ ... with a ∩̃ b = max(a, b) + R·k³/6, k = max(1 - |a - b|/R, 0) (§4.2 in
// our sign convention): core/Combinators.h's SmoothBlend, inlined into the loop.
__attribute__((noinline)) void fold(const PlaneSoA& P, const std::vector<int>& act, float R, int n,
          const float* __restrict x, const float* __restrict y, const float* __restrict z,
          float* __restrict f)
{
    const int k0 = act[0];
    {
        const float ax = P.nx[size_t(k0)], ay = P.ny[size_t(k0)], az = P.nz[size_t(k0)],
                    ad = P.d[size_t(k0)];
        for (int i = 0; i < n; ++i) f[i] = ax * x[i] + ay * y[i] + az * z[i] - ad;
    }
    const SmoothBlend blend(R);
    for (size_t a = 1; a < act.size(); ++a) {
        const size_t k = size_t(act[a]);
        const float ax = P.nx[k], ay = P.ny[k], az = P.nz[k], ad = P.d[k];
        if (R > 0) {
            for (int i = 0; i < n; ++i) {
                f[i] = blend.intersection(f[i], ax * x[i] + ay * y[i] + az * z[i] - ad);
            }
        } else {
            for (int i = 0; i < n; ++i) f[i] = std::max(f[i], ax * x[i] + ay * y[i] + az * z[i] - ad);
        }
    }
}

// The same fold with its gradient (forward mode): ∂(a ∩̃ b)/∂a = 1 - k²/2 where a >= b,
// k²/2 where a < b, and symmetrically for b.
__attribute__((noinline)) void foldGrad(const PlaneSoA& P, const std::vector<int>& act, float R, int n,
              const float* __restrict x, const float* __restrict y, const float* __restrict z,
              float* __restrict f, float* __restrict gx, float* __restrict gy,
              float* __restrict gz)
{
    const size_t k0 = size_t(act[0]);
    for (int i = 0; i < n; ++i) {
        f[i] = P.nx[k0] * x[i] + P.ny[k0] * y[i] + P.nz[k0] * z[i] - P.d[k0];
        gx[i] = P.nx[k0];
        gy[i] = P.ny[k0];
        gz[i] = P.nz[k0];
    }
    const SmoothBlend blend(R);
    for (size_t a = 1; a < act.size(); ++a) {
        const size_t k = size_t(act[a]);
        const float ax = P.nx[k], ay = P.ny[k], az = P.nz[k], ad = P.d[k];
        if (R > 0) {
            // Branch-free so the loop vectorises: sel = [f >= h].
            for (int i = 0; i < n; ++i) {
                const float h = ax * x[i] + ay * y[i] + az * z[i] - ad;
                const float diff = f[i] - h;
                const float kk = blend.k(f[i], h);
                const float half = 0.5f * kk * kk;
                const float sel = diff >= 0.0f ? 1.0f : 0.0f;
                const float wf = half + sel * (1.0f - 2.0f * half), wh = 1.0f - wf;
                gx[i] = wf * gx[i] + wh * ax;
                gy[i] = wf * gy[i] + wh * ay;
                gz[i] = wf * gz[i] + wh * az;
                f[i] = std::max(f[i], h) + blend.r6 * kk * kk * kk;
            }
        } else {
            for (int i = 0; i < n; ++i) {
                const float h = ax * x[i] + ay * y[i] + az * z[i] - ad;
                const float sel = f[i] >= h ? 1.0f : 0.0f;
                gx[i] = sel * gx[i] + (1.0f - sel) * ax;
                gy[i] = sel * gy[i] + (1.0f - sel) * ay;
                gz[i] = sel * gz[i] + (1.0f - sel) * az;
                f[i] = std::max(f[i], h);
            }
        }
    }
}

// An authored expression block (image) that keeps this block fracture-width away from it.
struct Carver
{
    int block;
    std::array<int, 3> image; // the carver's frame → this block's, in tiles
    Vec3f offset;             // the same in metres
};

struct BlockShape
{
    BlockKind kind;
    PlaneSoA planes;
    Vec3f a, ba;     // segment a and b - a (point: ba = 0)
    float invLen2 = 0, radius = 0;
    Vec3f lo, hi;    // bounds of the warped block (unwarped bounds + amplitude)
    FieldPtr expr;   // expression block: its field, at p - origin
    Vec3f origin = Vec3f(0.0f);
    std::vector<Carver> carvers;
};

// Scratch for one block evaluation (a batch of at most kMaxBatch points).
struct Work
{
    alignas(64) float f[kMaxBatch], gx[kMaxBatch], gy[kMaxBatch], gz[kMaxBatch];
    alignas(64) float qx[kMaxBatch], qy[kMaxBatch], qz[kMaxBatch];
    alignas(64) float lx[kMaxBatch], ly[kMaxBatch], lz[kMaxBatch];
    alignas(64) float dxy[kMaxBatch], dxz[kMaxBatch], dyz[kMaxBatch];
    alignas(64) float ex[kMaxBatch], ey[kMaxBatch], ez[kMaxBatch];
    std::vector<int> act;
    std::unique_ptr<Work> inner; // a carver's evaluation (made on first use)
    // Carver values of this batch by (block, image in tiles): several neighbours of one
    // expression block share its evaluation.
    std::vector<std::pair<std::array<int, 4>, std::vector<float>>> carved;
};

class Blocks
{
public:
    explicit Blocks(const BlockTile& tile)
        : mRelief(tile.params.relief, tile.params.seed, coordinateLow(tile), coordinateHigh(tile)),
          mR(float(tile.params.smoothRadius)),
          mP(float(tile.params.relief.sharpness))
    {
        const float amp = mRelief.amplitude();
        for (const Block& b : tile.blocks) {
            BlockShape s;
            s.kind = b.kind;
            for (const auto& q : b.planes) {
                s.planes.nx.push_back(q[0]);
                s.planes.ny.push_back(q[1]);
                s.planes.nz.push_back(q[2]);
                s.planes.d.push_back(q[3]);
            }
            s.a = Vec3f(b.a[0], b.a[1], b.a[2]);
            s.ba = Vec3f(b.b[0], b.b[1], b.b[2]) - s.a;
            s.invLen2 = s.ba.lengthSqr() > 0 ? 1.0f / s.ba.lengthSqr() : 0.0f;
            s.radius = b.radius;
            s.lo = Vec3f(b.boundsMin[0], b.boundsMin[1], b.boundsMin[2]) - Vec3f(amp);
            s.hi = Vec3f(b.boundsMax[0], b.boundsMax[1], b.boundsMax[2]) + Vec3f(amp);
            if (b.kind == BlockKind::Expression) {
                s.expr = authoredExpressionField(b.expression, "expression block " +
                                                                   std::to_string(mShapes.size()));
                s.origin = Vec3f(b.origin[0], b.origin[1], b.origin[2]);
            }
            mShapes.push_back(std::move(s));
        }
        // The box term sits this far outside each block's box (far from the band).
        mMargin = std::max(0.5f, 2.0f * (mR + amp));
        // Each expression block keeps every later block (and image) whose box comes within
        // w of its own fracture-width away: b_j ∩̃ (w − b_a), in the warped frame.
        mW = float(tile.params.fractureWidth);
        const float S = float(tile.size());
        for (size_t a = 0; a < mShapes.size(); ++a) {
            if (mShapes[a].kind != BlockKind::Expression) continue;
            for (size_t j = a + 1; j < mShapes.size(); ++j) {
                BlockShape& J = mShapes[j];
                for (int i = -2; i <= 2; ++i)
                    for (int k = -2; k <= 2; ++k)
                        for (int l = -2; l <= 2; ++l) {
                            const Vec3f off(float(i) * S, float(k) * S, float(l) * S);
                            bool near = true;
                            for (int c = 0; c < 3 && near; ++c) {
                                near = mShapes[a].lo[c] + off[c] - mW - mR < J.hi[c] &&
                                       J.lo[c] < mShapes[a].hi[c] + off[c] + mW + mR;
                            }
                            if (near) J.carvers.push_back({int(a), {i, k, l}, off});
                        }
            }
        }
    }

    size_t size() const { return mShapes.size(); }
    const BlockShape& shape(size_t j) const { return mShapes[j]; }
    float amplitude() const { return mRelief.amplitude(); }
    float margin() const { return mMargin; }

    // Signed distance from p to the block's (warped) box, exact outside.
    float boxDistance(size_t j, const Vec3f& p) const
    {
        const BlockShape& s = mShapes[j];
        float out2 = 0, in = -kInf;
        for (int a = 0; a < 3; ++a) {
            const float q = std::max(s.lo[a] - p[a], p[a] - s.hi[a]);
            if (q > 0) out2 += q * q;
            in = std::max(in, q);
        }
        return out2 > 0 ? std::sqrt(out2) : in;
    }

    // A lower bound of b_j over the ball (c, ρ) (local coordinates).
    float lowerBound(size_t j, const Vec3f& c, float rho) const
    {
        const BlockShape& s = mShapes[j];
        float lb = boxDistance(j, c) - rho - mMargin;
        if (s.kind == BlockKind::Polytope) {
            lb = std::max(lb, maxPlane(s.planes, c) - rho - mRelief.amplitude());
        }
        return lb;
    }

    // Relief at the three projections of the local points (shared by blocks in one frame).
    void relief(int n, const float* x, const float* y, const float* z, Work& w) const
    {
        if (mRelief.amplitude() <= 0) return;
        for (int i = 0; i < n; ++i) {
            w.dxy[i] = mRelief(x[i], y[i]);
            w.dxz[i] = mRelief(x[i], z[i]);
            w.dyz[i] = mRelief(y[i], z[i]);
        }
    }

    // b'_j at n local points (relief already in w): c_j(p + δ(p)), raised to the box term,
    // carved by the expression blocks before it. Values of magnitude >= band are all alike
    // to the caller (carvers that cannot reach the band are skipped).
    void eval(size_t j, int n, const float* x, const float* y, const float* z,
              const Vec3f& centre, float rho, Work& w, float* out, float band = kInf,
              const std::array<int, 3>& image = {0, 0, 0}) const
    {
        const BlockShape& s = mShapes[j];
        const float amp = mRelief.amplitude();
        const float* px = x;
        const float* py = y;
        const float* pz = z;
        if (amp > 0) {
            // ω⁻¹(p) = p + g(p)·Σ α_i d(γ_i(p)), g = ∇c/|∇c|, α_i = |g_i|^p / Σ|g_j|^p
            // (the paper's |g·u_i|, normalised so |δ| <= A: the surface moves <= A).
            gradient(s, n, x, y, z, centre, rho, w);
            const float pexp = mP;
            for (int i = 0; i < n; ++i) {
                const float len = std::sqrt(w.gx[i] * w.gx[i] + w.gy[i] * w.gy[i] + w.gz[i] * w.gz[i]);
                const float inv = 1.0f / std::max(len, 1e-6f);
                w.gx[i] *= inv;
                w.gy[i] *= inv;
                w.gz[i] *= inv;
                w.f[i] = std::min(len, 1.0f);
            }
            for (int i = 0; i < n; ++i) {
                const float disp = relief::triplanar(w.gx[i], w.gy[i], w.gz[i], w.dxy[i],
                                                     w.dxz[i], w.dyz[i], pexp);
                const float scale = w.f[i] * disp;
                w.qx[i] = x[i] + w.gx[i] * scale;
                w.qy[i] = y[i] + w.gy[i] * scale;
                w.qz[i] = z[i] + w.gz[i] * scale;
            }
            px = w.qx;
            py = w.qy;
            pz = w.qz;
        }
        base(s, n, px, py, pz, centre, rho + amp, w, out);
        // Box term, vectorised: signed distance to the box, lowered by the margin.
        const float lx = s.lo[0], ly = s.lo[1], lz = s.lo[2], hx = s.hi[0], hy = s.hi[1],
                    hz = s.hi[2], m = mMargin;
        for (int i = 0; i < n; ++i) {
            const float qx = std::max(lx - x[i], x[i] - hx), qy = std::max(ly - y[i], y[i] - hy),
                        qz = std::max(lz - z[i], z[i] - hz);
            const float ox = std::max(qx, 0.0f), oy = std::max(qy, 0.0f), oz = std::max(qz, 0.0f);
            const float in = std::min(std::max(qx, std::max(qy, qz)), 0.0f);
            out[i] = std::max(out[i], std::sqrt(ox * ox + oy * oy + oz * oz) + in - m);
        }
        for (const Carver& c : s.carvers) carve(c, n, x, y, z, centre, rho, w, out, band, image);
    }

private:
    // out = out ∩̃ (w − b_a) for the carver's image: where b_a < w the block gives way.
    // Skipped when b_a >= w + band + 2R over the whole batch: then w − b_a <= −band − 2R, so
    // the result differs from out only where both lie below −band (alike to the caller).
    // @a image: this block's copy (tiles), so copies of one carver share one evaluation.
    void carve(const Carver& c, int n, const float* x, const float* y, const float* z,
               const Vec3f& centre, float rho, Work& w, float* out, float band,
               const std::array<int, 3>& image) const
    {
        const Vec3f lc = centre - c.offset;
        if (lowerBound(size_t(c.block), lc, rho) >= mW + band + 2.0f * mR) return;
        const std::array<int, 4> key{c.block, image[0] + c.image[0], image[1] + c.image[1],
                                     image[2] + c.image[2]};
        const float* value = nullptr;
        for (const auto& e : w.carved) if (e.first == key) value = e.second.data();
        if (!value) {
            if (!w.inner) w.inner = std::make_unique<Work>();
            Work& v = *w.inner;
            for (int i = 0; i < n; ++i) {
                v.lx[i] = x[i] - c.offset[0];
                v.ly[i] = y[i] - c.offset[1];
                v.lz[i] = z[i] - c.offset[2];
            }
            relief(n, v.lx, v.ly, v.lz, v);
            w.carved.emplace_back(key, std::vector<float>(size_t(n)));
            const std::array<int, 3> at{key[1], key[2], key[3]};
            eval(size_t(c.block), n, v.lx, v.ly, v.lz, lc, rho, v, w.carved.back().second.data(),
                 band, at);
            value = w.carved.back().second.data();
        }
        const SmoothBlend blend(mR);
        for (int i = 0; i < n; ++i) out[i] = blend.intersection(out[i], mW - value[i]);
    }

    // An expression block's points, moved into its own frame (p − origin), as a batch.
    Batch exprBatch(const BlockShape& s, int n, const float* x, const float* y, const float* z,
                    const Vec3f& centre, float rho, Work& w) const
    {
        for (int i = 0; i < n; ++i) {
            w.ex[i] = x[i] - s.origin[0];
            w.ey[i] = y[i] - s.origin[1];
            w.ez[i] = z[i] - s.origin[2];
        }
        Batch b{w.ex, w.ey, w.ez, n};
        b.center = centre - s.origin;
        b.radius = rho;
        return b; // band and reach stay infinite: the warp reads exact values
    }

    // c_j (unwarped base) at n points within ρ of centre.
    void base(const BlockShape& s, int n, const float* x, const float* y, const float* z,
              const Vec3f& centre, float rho, Work& w, float* out) const
    {
        if (s.kind == BlockKind::Polytope) {
            activePlanes(s.planes, centre, rho, mR, w.act);
            fold(s.planes, w.act, mR, n, x, y, z, out);
            return;
        }
        if (s.kind == BlockKind::Expression) {
            s.expr->evalBatch(exprBatch(s, n, x, y, z, centre, rho, w), out);
            return;
        }
        for (int i = 0; i < n; ++i) {
            const float px = x[i] - s.a[0], py = y[i] - s.a[1], pz = z[i] - s.a[2];
            const float h = std::min(std::max((px * s.ba[0] + py * s.ba[1] + pz * s.ba[2]) * s.invLen2, 0.0f), 1.0f);
            const float dx = px - s.ba[0] * h, dy = py - s.ba[1] * h, dz = pz - s.ba[2] * h;
            out[i] = std::sqrt(dx * dx + dy * dy + dz * dz) - s.radius;
        }
    }

    void gradient(const BlockShape& s, int n, const float* x, const float* y, const float* z,
                  const Vec3f& centre, float rho, Work& w) const
    {
        if (s.kind == BlockKind::Polytope) {
            activePlanes(s.planes, centre, rho, mR, w.act);
            foldGrad(s.planes, w.act, mR, n, x, y, z, w.f, w.gx, w.gy, w.gz);
            return;
        }
        if (s.kind == BlockKind::Expression) {
            // Central differences (a millimetre); only the direction is used.
            s.expr->gradientBatch(exprBatch(s, n, x, y, z, centre, rho, w), 1e-3f, w.gx, w.gy, w.gz);
            return;
        }
        for (int i = 0; i < n; ++i) {
            const float px = x[i] - s.a[0], py = y[i] - s.a[1], pz = z[i] - s.a[2];
            const float h = std::min(std::max((px * s.ba[0] + py * s.ba[1] + pz * s.ba[2]) * s.invLen2, 0.0f), 1.0f);
            w.gx[i] = px - s.ba[0] * h;
            w.gy[i] = py - s.ba[1] * h;
            w.gz[i] = pz - s.ba[2] * h;
            const float len = std::sqrt(w.gx[i] * w.gx[i] + w.gy[i] * w.gy[i] + w.gz[i] * w.gz[i]);
            const float inv = len > 0 ? 1.0f / len : 0.0f;
            w.gx[i] *= inv;
            w.gy[i] *= inv;
            w.gz[i] *= inv;
        }
    }

    std::vector<BlockShape> mShapes;
    relief::Relief mRelief;
    float mR, mP, mMargin = 0.5f, mW = 0.0f;
};

// A slope bound of the warped blocks, for the renormaliser's floor only (|∇δ| from the relief
// and the curvature of the rounded edges, generously): 1 + L_δ.
double warpedSlope(const BlockTile& t)
{
    const double amp = t.params.relief.amplitude;
    if (amp <= 0) return 1.0;
    const double r = std::max(1e-3, t.params.smoothRadius);
    return 1.0 + amp * (8.0 / r + 2.8 * noise::kGradientBound2 * 4.0 / t.params.relief.scale);
}

} // namespace

double tileFieldBytes(const BlockTile& t)
{
    double bytes = double(relief::tableTexels(t.params.relief, coordinateLow(t), coordinateHigh(t))) * sizeof(float);
    for (const auto& b : t.blocks) {
        bytes += double(sizeof(BlockShape) + b.planes.size() * 4 * sizeof(float) + b.anchors.size() * sizeof(b.anchors[0]));
    }
    return bytes;
}

namespace {

// One evaluator (and relief table) per tile, shared by its tile field and block fields.
std::shared_ptr<const Blocks> blocksFor(const std::shared_ptr<const BlockTile>& tile)
{
    static std::mutex mutex;
    static std::vector<std::pair<std::weak_ptr<const BlockTile>, std::weak_ptr<const Blocks>>> cache;
    std::lock_guard<std::mutex> lock(mutex);
    cache.erase(std::remove_if(cache.begin(), cache.end(),
                               [](const auto& e) { return e.first.expired() || e.second.expired(); }),
                cache.end());
    for (const auto& e : cache) {
        if (e.first.lock() == tile) {
            if (auto b = e.second.lock()) return b;
        }
    }
    auto b = std::make_shared<const Blocks>(*tile);
    cache.emplace_back(tile, b);
    return b;
}

// ---- the tile field ---------------------------------------------------------------------

struct Candidate
{
    int block;
    int ix, iy, iz; // image translation in tiles (world = local + s·(ix, iy, iz))
    bool operator<(const Candidate& o) const
    {
        return std::tie(ix, iy, iz, block) < std::tie(o.ix, o.iy, o.iz, o.block);
    }
    bool operator==(const Candidate& o) const
    {
        return block == o.block && ix == o.ix && iy == o.iy && iz == o.iz;
    }
};

class TileField final : public Field
{
public:
    TileField(std::shared_ptr<const BlockTile> tile, const TileFieldOptions& o)
        : mTile(std::move(tile)), mOpt(o), mBlocksPtr(blocksFor(mTile)), mBlocks(*mBlocksPtr),
          mS(float(mTile->size()))
    {
        const double s = mTile->size();
        // Exact range C: values are min(t, C). Every point is close to some block in a
        // fractured tile, so C = s/4 is only reached far outside a finite copy range.
        mCap = float(s / 4.0);
        const double reachM = double(mCap) + double(mBlocks.margin());
        mN = std::max(1, std::min(16, int(std::round(s / 2.5))));
        mCell = s / mN;
        mCells.resize(size_t(mN) * mN * mN);
        for (size_t j = 0; j < mBlocks.size(); ++j) {
            const BlockShape& b = mBlocks.shape(j);
            int lo[3], hi[3];
            for (int a = 0; a < 3; ++a) {
                lo[a] = int(std::floor((double(b.lo[a]) - reachM) / s));
                hi[a] = int(std::floor((double(b.hi[a]) + reachM) / s));
            }
            for (int i = lo[0] - 1; i <= hi[0] + 1; ++i)
                for (int k = lo[1] - 1; k <= hi[1] + 1; ++k)
                    for (int l = lo[2] - 1; l <= hi[2] + 1; ++l) {
                        // Image (i, k, l) of block j: cells of the home tile within reachM.
                        int c0[3], c1[3];
                        const int img[3] = {i, k, l};
                        bool any = true;
                        for (int a = 0; a < 3; ++a) {
                            const double blo = double(b.lo[a]) + img[a] * s - reachM;
                            const double bhi = double(b.hi[a]) + img[a] * s + reachM;
                            c0[a] = std::max(0, int(std::floor(blo / mCell)));
                            c1[a] = std::min(mN - 1, int(std::floor(bhi / mCell)));
                            if (c0[a] > c1[a]) any = false;
                        }
                        if (!any) continue;
                        for (int x = c0[0]; x <= c1[0]; ++x)
                            for (int y = c0[1]; y <= c1[1]; ++y)
                                for (int z = c0[2]; z <= c1[2]; ++z) {
                                    mCells[(size_t(x) * mN + y) * mN + z].push_back(
                                        {int(j), i, k, l});
                                }
                    }
        }
        // Bounds of a finite copy range: the blocks' boxes over the copies.
        if (mOpt.presence) {
            mBounds = mOpt.presence->bounds();
        } else if (!mOpt.periodic) {
            bool first = true;
            for (size_t j = 0; j < mBlocks.size(); ++j) {
                const BlockShape& b = mBlocks.shape(j);
                for (int i = 0; i < mOpt.periods[0]; ++i)
                    for (int k = 0; k < mOpt.periods[1]; ++k)
                        for (int l = 0; l < mOpt.periods[2]; ++l) {
                            const Vec3d t(i * s, k * s, l * s);
                            const BBoxd bb(Vec3d(b.lo) + t, Vec3d(b.hi) + t);
                            if (first) { mBounds = bb; first = false; } else mBounds.expand(bb);
                        }
            }
            if (first) mBounds = BBoxd(); // no blocks: empty
        }
    }

    void evalBatch(const Batch& b, float* out) const override { eval(b, out, nullptr); }
    void evalIdBatch(const Batch& b, float* out, float* id) const override { eval(b, out, id); }

    BBoxd bounds() const override
    {
        if (mOpt.presence) return mBounds;
        if (mOpt.periodic) return infiniteBounds();
        if (mBlocks.size() == 0) return BBoxd(Vec3d(0), Vec3d(-1)); // empty
        return mBounds;
    }
    // |b(p) - b(q)| <= |p - q| + |δ(p) - δ(q)| <= |p - q| + 2A; min, max and the cap keep it.
    double modulus(double r) const override { return r + 2.0 * double(mBlocks.amplitude()); }
    double lipschitz() const override { return warpedSlope(*mTile); }
    bool exact() const override { return false; }

private:
    // With cullPerOctant, large batches (a baker's padded leaf) are split into octants around
    // their centre, each culled on its own: a block or plane that can matter for one corner
    // of a leaf is not evaluated over the other seven. Values within the band are the same
    // either way (only blocks and planes proven beyond it are skipped).
    void eval(const Batch& b, float* out, float* id) const
    {
        if (!mOpt.cullPerOctant || b.n <= kSplitBelow || !std::isfinite(b.radius) ||
            !std::isfinite(b.band)) {
            evalOne(b, out, id);
            return;
        }
        BatchBuffer sub;
        sub.band = b.band;
        sub.reach = b.reach;
        alignas(64) int index[kMaxBatch];
        alignas(64) float subOut[kMaxBatch], subId[kMaxBatch];
        for (int octant = 0; octant < 8; ++octant) {
            int m = 0;
            Vec3f lo(kInf), hi(-kInf);
            for (int i = 0; i < b.n; ++i) {
                const int o = (b.x[i] >= b.center[0] ? 4 : 0) | (b.y[i] >= b.center[1] ? 2 : 0) |
                              (b.z[i] >= b.center[2] ? 1 : 0);
                if (o != octant) continue;
                sub.x[m] = b.x[i];
                sub.y[m] = b.y[i];
                sub.z[m] = b.z[i];
                lo = minComponent(lo, Vec3f(b.x[i], b.y[i], b.z[i]));
                hi = maxComponent(hi, Vec3f(b.x[i], b.y[i], b.z[i]));
                index[m++] = i;
            }
            if (m == 0) continue;
            sub.n = m;
            sub.center = (lo + hi) * 0.5f;
            // Half the box's diagonal, padded for the float rounding of the centre.
            sub.radius = (hi - lo).length() * 0.5f * (1.0f + 1e-5f) + 1e-6f;
            evalOne(sub.view(), subOut, id ? subId : nullptr);
            for (int k = 0; k < m; ++k) out[index[k]] = subOut[k];
            if (id) for (int k = 0; k < m; ++k) id[index[k]] = subId[k];
        }
    }

    static constexpr int kSplitBelow = 256;

    void evalOne(const Batch& b, float* out, float* id) const
    {
        if (std::isfinite(b.band) && b.band > mCap) {
            fail<ValueError>("blocks: the bake's band (", b.band, " m) exceeds the tile field's "
                             "exact range (tile size / 4 = ", mCap, " m); use a smaller voxel size");
        }
        // Cells touched by the batch's box (in the infinite lattice of cells).
        Vec3f lo(kInf), hi(-kInf);
        if (std::isfinite(b.radius)) {
            lo = b.center - Vec3f(b.radius);
            hi = b.center + Vec3f(b.radius);
        } else {
            for (int i = 0; i < b.n; ++i) {
                lo = minComponent(lo, Vec3f(b.x[i], b.y[i], b.z[i]));
                hi = maxComponent(hi, Vec3f(b.x[i], b.y[i], b.z[i]));
            }
        }
        std::vector<Candidate> cand;
        int c0[3], c1[3];
        for (int a = 0; a < 3; ++a) {
            c0[a] = int(std::floor(double(lo[a]) / mCell));
            c1[a] = int(std::floor(double(hi[a]) / mCell));
        }
        for (int x = c0[0]; x <= c1[0]; ++x)
            for (int y = c0[1]; y <= c1[1]; ++y)
                for (int z = c0[2]; z <= c1[2]; ++z) {
                    const int T[3] = {floorDiv(x, mN), floorDiv(y, mN), floorDiv(z, mN)};
                    const auto& list = mCells[(size_t(x - T[0] * mN) * mN + (y - T[1] * mN)) * mN +
                                              (z - T[2] * mN)];
                    for (const auto& e : list) {
                        Candidate c{e.block, e.ix + T[0], e.iy + T[1], e.iz + T[2]};
                        if (mOpt.presence) {
                            if (!mOpt.presence->present(c.block, c.ix, c.iy, c.iz)) continue;
                        } else if (!mOpt.periodic &&
                            (c.ix < 0 || c.ix >= mOpt.periods[0] || c.iy < 0 ||
                             c.iy >= mOpt.periods[1] || c.iz < 0 || c.iz >= mOpt.periods[2])) {
                            continue;
                        }
                        cand.push_back(c);
                    }
                }
        std::sort(cand.begin(), cand.end());
        cand.erase(std::unique(cand.begin(), cand.end()), cand.end());

        // Batch centre and radius (the baker's hints, or the points' box).
        Vec3f centre = std::isfinite(b.radius) ? b.center : (lo + hi) * 0.5f;
        const float rho = std::isfinite(b.radius) ? b.radius : (hi - lo).length() * 0.5f;

        std::fill(out, out + b.n, mCap);
        if (id) std::fill(id, id + b.n, kNoId);
        Work w;
        alignas(64) float v[kMaxBatch];
        int frame[3] = {INT32_MIN, 0, 0};
        for (const Candidate& c : cand) {
            const Vec3f shift(float(c.ix) * mS, float(c.iy) * mS, float(c.iz) * mS);
            const Vec3f lc = centre - shift;
            // Blocks that stay beyond the band over the whole batch change nothing after the
            // caller's clamping.
            if (std::isfinite(b.band) && mBlocks.lowerBound(size_t(c.block), lc, rho) >= b.band) {
                continue;
            }
            if (frame[0] != c.ix || frame[1] != c.iy || frame[2] != c.iz) {
                frame[0] = c.ix; frame[1] = c.iy; frame[2] = c.iz;
                for (int i = 0; i < b.n; ++i) {
                    w.lx[i] = b.x[i] - shift[0];
                    w.ly[i] = b.y[i] - shift[1];
                    w.lz[i] = b.z[i] - shift[2];
                }
                mBlocks.relief(b.n, w.lx, w.ly, w.lz, w);
            }
            mBlocks.eval(size_t(c.block), b.n, w.lx, w.ly, w.lz, lc, rho, w, v, b.band,
                         {c.ix, c.iy, c.iz});
            if (id) {
                const float bid = (mOpt.blockIds ? (*mOpt.blockIds)[size_t(c.block)] : float(c.block)) +
                                  mOpt.idOffset;
                for (int i = 0; i < b.n; ++i) {
                    if (v[i] < out[i]) { out[i] = v[i]; id[i] = bid; }
                }
            } else {
                for (int i = 0; i < b.n; ++i) out[i] = std::min(out[i], v[i]);
            }
        }
    }

    std::shared_ptr<const BlockTile> mTile;
    TileFieldOptions mOpt;
    std::shared_ptr<const Blocks> mBlocksPtr;
    const Blocks& mBlocks;
    float mS;
    float mCap = 5.0f;
    int mN = 1;
    double mCell = 1;
    std::vector<std::vector<Candidate>> mCells;
    BBoxd mBounds;
};

class SingleBlock final : public Field
{
public:
    SingleBlock(std::shared_ptr<const BlockTile> tile, size_t j)
        : mTile(std::move(tile)), mBlocksPtr(blocksFor(mTile)), mBlocks(*mBlocksPtr), mJ(j) {}

    void evalBatch(const Batch& b, float* out) const override
    {
        Vec3f lo(kInf), hi(-kInf);
        for (int i = 0; i < b.n; ++i) {
            lo = minComponent(lo, Vec3f(b.x[i], b.y[i], b.z[i]));
            hi = maxComponent(hi, Vec3f(b.x[i], b.y[i], b.z[i]));
        }
        const Vec3f centre = std::isfinite(b.radius) ? b.center : (lo + hi) * 0.5f;
        const float rho = std::isfinite(b.radius) ? b.radius : (hi - lo).length() * 0.5f;
        Work w;
        mBlocks.relief(b.n, b.x, b.y, b.z, w);
        mBlocks.eval(mJ, b.n, b.x, b.y, b.z, centre, rho, w, out);
    }
    BBoxd bounds() const override
    {
        const BlockShape& s = mBlocks.shape(mJ);
        return BBoxd(Vec3d(s.lo), Vec3d(s.hi));
    }
    double modulus(double r) const override { return r + 2.0 * double(mBlocks.amplitude()); }
    double lipschitz() const override { return warpedSlope(*mTile); }
    bool exact() const override { return false; }

private:
    std::shared_ptr<const BlockTile> mTile;
    std::shared_ptr<const Blocks> mBlocksPtr;
    const Blocks& mBlocks;
    size_t mJ;
};

} // namespace

FieldPtr tileField(std::shared_ptr<const BlockTile> tile, const TileFieldOptions& options)
{
    if (!tile) fail<ValueError>("blocks: tile is null");
    for (int a = 0; a < 3; ++a) {
        require(options.periods[size_t(a)] >= 1 && options.periods[size_t(a)] <= 64, "blocks",
                "periods", "in [1, 64] per axis", options.periods[size_t(a)]);
    }
    if (options.blockIds && options.blockIds->size() != tile->blocks.size()) {
        fail<ValueError>("blocks: ", options.blockIds->size(), " block ids for ", tile->blocks.size(), " blocks");
    }
    return std::make_shared<TileField>(std::move(tile), options);
}

FieldPtr blockField(std::shared_ptr<const BlockTile> tile, size_t index)
{
    if (!tile) fail<ValueError>("blocks: tile is null");
    if (index >= tile->blocks.size()) {
        fail<ValueError>("blocks: block index ", index, " out of range (", tile->blocks.size(),
                         " blocks)");
    }
    return std::make_shared<SingleBlock>(std::move(tile), index);
}

} // namespace blocks
} // namespace rockvdb
