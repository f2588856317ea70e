// SPDX-License-Identifier: Apache-2.0
#include "Detail.h"

#include <rockvdb/detail/Gabor.h>

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/GridField.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <memory>

namespace rockvdb {
namespace detail {

using namespace relief;

using json = nlohmann::json;

namespace {

constexpr int kGaborTrackerSteps = 3;
constexpr int kMaxWidenVoxels = 64;

float smoothstep(float a, float b, float x)
{
    const float t = std::min(std::max((x - a) / (b - a), 0.0f), 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

// q minus the point of @a pr nearest q, and that point's barycentric coordinates (weights of
// the primitive's vertices; Ericson, Real-Time Collision Detection §5.1.5 for triangles).
Vec3d nearest(const Primitive& pr, const Vec3d& q, double bary[3])
{
    bary[0] = 1.0;
    bary[1] = bary[2] = 0.0;
    if (pr.count == 1) return q - pr.v[0];
    const Vec3d& a = pr.v[0];
    const Vec3d& b = pr.v[1];
    if (pr.count == 2) {
        const Vec3d ab = b - a;
        const double t = std::clamp((q - a).dot(ab) / ab.lengthSqr(), 0.0, 1.0);
        bary[0] = 1.0 - t;
        bary[1] = t;
        return q - (a + ab * t);
    }
    const Vec3d& c = pr.v[2];
    const Vec3d ab = b - a, ac = c - a, ap = q - a;
    auto set = [&](double u, double v, double w) {
        bary[0] = u;
        bary[1] = v;
        bary[2] = w;
        return q - (a * u + b * v + c * w);
    };
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) return set(1, 0, 0);
    const Vec3d bp = q - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) return set(0, 1, 0);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        const double v = d1 / (d1 - d3);
        return set(1 - v, v, 0);
    }
    const Vec3d cp = q - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) return set(0, 0, 1);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        const double w = d2 / (d2 - d6);
        return set(1 - w, 0, w);
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return set(0, 1 - w, w);
    }
    const double denom = 1.0 / (va + vb + vc);
    const double v = vb * denom, w = vc * denom;
    return set(1 - v - w, v, w);
}

// World-space trilinear samples of a blend mask, clamped to [0, 1].
class MaskSampler
{
public:
    explicit MaskSampler(openvdb::FloatGrid::ConstPtr g) : mGrid(std::move(g)) {}
    float operator()(float x, float y, float z) const
    {
        const Vec3d ijk = mGrid->transform().worldToIndex(Vec3d(x, y, z));
        const float v = openvdb::tools::BoxSampler::sample(mGrid->tree(), ijk);
        return std::min(std::max(v, 0.0f), 1.0f);
    }

private:
    openvdb::FloatGrid::ConstPtr mGrid;
};

float lerp(float a, float b, float w) { return a + (b - a) * w; }

// tools::BoxSampler::sample(acc, x) bit for bit (the same corners, double weights and order
// of operations), with the eight corners read from one leaf's buffer when they lie in it: one
// tree lookup instead of eight.
float boxSample(const openvdb::FloatGrid::ConstAccessor& acc, const Vec3d& x)
{
    auto ifloor = [](double v) { // std::floor for |v| < 2^31, without a libm call
        const int i = int(v);
        return i - (double(i) > v ? 1 : 0);
    };
    const openvdb::Coord c(ifloor(x[0]), ifloor(x[1]), ifloor(x[2]));
    const Vec3d uvw = x - Vec3d(c.x(), c.y(), c.z());
    float d[2][2][2];
    const int lx = c.x() & 7, ly = c.y() & 7, lz = c.z() & 7;
    const auto* leaf = (lx < 7 && ly < 7 && lz < 7) ? acc.probeConstLeaf(c) : nullptr;
    if (leaf) {
        const float* v = leaf->buffer().data() + ((lx << 6) | (ly << 3) | lz);
        d[0][0][0] = v[0];  d[0][0][1] = v[1];  d[0][1][0] = v[8];  d[0][1][1] = v[9];
        d[1][0][0] = v[64]; d[1][0][1] = v[65]; d[1][1][0] = v[72]; d[1][1][1] = v[73];
    } else {
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j)
                for (int k = 0; k < 2; ++k) d[i][j][k] = acc.getValue(c.offsetBy(i, j, k));
    }
    auto mix = [](float a, float b, double w) { return float(a + float((b - a) * w)); };
    return mix(mix(mix(d[0][0][0], d[0][0][1], uvw[2]), mix(d[0][1][0], d[0][1][1], uvw[2]), uvw[1]),
               mix(mix(d[1][0][0], d[1][0][1], uvw[2]), mix(d[1][1][0], d[1][1][1], uvw[2]), uvw[1]),
               uvw[0]);
}

// ---- §4.2 gradient-based warp: f(ω⁻¹(p)), ω⁻¹(p) = p + g(p) Σ α_i d(γ_i(p)) ----------------

class GradientWarp final : public Field
{
public:
    // The relief is built at amplitude A = max(A_base, A_blend); with a blend the warp at p is
    // scaled by lerp(A_base, A_blend, w(p)) / A.
    GradientWarp(FieldPtr input, const ReliefParams& r, uint64_t seed, float h, float lo, float hi,
                 float baseAmplitude, float blendAmplitude, openvdb::FloatGrid::ConstPtr mask)
        : mInput(std::move(input)), mRelief(r, seed, lo, hi), mP(float(r.sharpness)), mH(h),
          mA(float(r.amplitude)), mBase(baseAmplitude / float(r.amplitude)),
          mBlend(blendAmplitude / float(r.amplitude))
    {
        if (mask) mMask = std::make_unique<MaskSampler>(std::move(mask));
    }

    void evalBatch(const Batch& b, float* out) const override { eval(b, out, nullptr); }
    void evalIdBatch(const Batch& b, float* out, float* id) const override { eval(b, out, id); }
    BBoxd bounds() const override
    {
        BBoxd bb = mInput->bounds();
        if (isBounded(bb)) bb.expand(double(mA));
        return bb;
    }
    double lipschitz() const override { return mInput->lipschitz() * (1.0 + slope()); }
    // |δ(p) - δ(q)| <= min(L_δ·|p - q|, 2A): the detail adds a constant, not a slope.
    double modulus(double r) const override
    {
        return mInput->modulus(r + std::min(slope() * r, 2.0 * double(mA)));
    }
    bool exact() const override { return false; }

private:
    // |∇δ| <= |∇d| + A·|∇g|·(1 + p), |∇g| bounded by the curvature the gradient step resolves
    // (1/h): loose, used only for the renormalisation floor.
    double slope() const
    {
        return mRelief.slopeBound() + double(mA) * (1.0 + double(mP)) / double(mH);
    }

    // Every point is warped: the leaves the bake visits all lie near the input surface (its
    // candidate mask), so testing f(p) first would cost a lookup and spare nothing.
    void eval(const Batch& b, float* out, float* id) const
    {
        alignas(64) float gx[kMaxBatch], gy[kMaxBatch], gz[kMaxBatch];
        mInput->gradientBatch(b, mH, gx, gy, gz);
        BatchBuffer q;
        for (int j = 0; j < b.n; ++j) {
            const float len = std::sqrt(gx[j] * gx[j] + gy[j] * gy[j] + gz[j] * gz[j]);
            const float inv = 1.0f / std::max(len, 1e-6f);
            const float nx = gx[j] * inv, ny = gy[j] * inv, nz = gz[j] * inv;
            const float x = b.x[j], y = b.y[j], z = b.z[j];
            // Where the gradient fades (medial axes of a distance, beyond the band) the warp
            // fades with it.
            float s = std::min(len, 1.0f) *
                      triplanar(nx, ny, nz, mRelief(x, y), mRelief(x, z), mRelief(y, z), mP);
            s *= mMask ? lerp(mBase, mBlend, (*mMask)(x, y, z)) : mBase;
            q.x[j] = x + nx * s;
            q.y[j] = y + ny * s;
            q.z[j] = z + nz * s;
        }
        q.n = b.n;
        q.center = b.center;
        q.radius = b.radius + mA;
        q.band = b.band;
        q.reach = std::isfinite(b.reach) ? b.reach + 2.0f * mA : b.reach;
        if (id) mInput->evalIdBatch(q.view(), out, id);
        else mInput->evalBatch(q.view(), out);
    }

    FieldPtr mInput;
    Relief mRelief;
    float mP, mH, mA;
    float mBase = 1, mBlend = 1;
    std::unique_ptr<MaskSampler> mMask;
};

// ---- gabor §3–§4: f(p) - D(n(p_S))·K(|p p_S|/R) in the band |f| < R ----------------------

class GaborDetail final : public Field
{
public:
    // value: the field to detail (the input, or the warped input); frames: the field whose
    // gradient gives the normals and projections (the unwarped input: far cheaper, and the
    // warp moves the surface by a small amount only).
    GaborDetail(FieldPtr value, FieldPtr frames, const GaborParams& g, const DirectionField& dir,
                float h, const BlendParams* blend = nullptr,
                openvdb::FloatGrid::ConstPtr mask = nullptr)
        : mInput(std::move(value)), mFrame(std::move(frames)), mG(g), mDir(dir),
          mNoise(g.frequency, g.bandwidth > 0 ? g.bandwidth : g.frequency / 2, g.impulses, g.seed),
          mH(h)
    {
        mA = float(g.amplitude);
        mR = falloff(g.falloff, g.amplitude);
        mD = intensity(mA, mR);
        mRmax = mR;
        mDmax = mD;
        mAmax = mA;
        if (blend && mask) {
            mBlend = *blend;
            mMask = std::make_unique<MaskSampler>(std::move(mask));
            const float a = float(blend->gaborAmplitude), r = falloff(blend->falloff, a);
            mRmax = std::max(mR, r);
            mDmax = std::max(mD, intensity(a, r));
            mAmax = std::max(mA, a);
        }
        const double alpha = g.tiltDeg * M_PI / 180.0, theta = g.tiltAzimuthDeg * M_PI / 180.0;
        mCosA = float(std::cos(alpha));
        mSinA = float(std::sin(alpha));
        mCosT = float(std::cos(theta));
        mSinT = float(std::sin(theta));
        const double w = g.orientationDeg * M_PI / 180.0;
        mCosW = float(std::cos(w));
        mSinW = float(std::sin(w));
        mSingular = g.singular;
        if (mSingular == Singular::Auto) {
            mSingular = dir.kind == DirectionKind::Axis ? Singular::Cancel : Singular::Isotropic;
        }
        // Parameters along the skeleton: their largest amplitude bounds the band.
        mSkeletonParams = dir.kind == DirectionKind::Skeleton && dir.hasParameters();
        if (mSkeletonParams && dir.maxAmplitude() > 0) {
            const float a = float(dir.maxAmplitude()), r = falloff(g.falloff, a);
            mRmax = std::max(mRmax, r);
            mDmax = std::max(mDmax, intensity(a, r));
            mAmax = std::max(mAmax, a);
        }
        mInvSigma = float(1.0 / mNoise.sigma());
        Vec3d ax = dir.axis;
        if (ax.length() > 0) ax.normalize();
        mAxis = Vec3f(float(ax[0]), float(ax[1]), float(ax[2]));
    }

    void evalBatch(const Batch& b, float* out) const override { eval(b, out, nullptr); }
    void evalIdBatch(const Batch& b, float* out, float* id) const override { eval(b, out, id); }
    BBoxd bounds() const override
    {
        BBoxd bb = mInput->bounds();
        if (isBounded(bb)) bb.expand(double(mAmax));
        return bb;
    }
    // |f_new - f| <= D: the modulus grows by 2D; the slope by D·(6/R + |∇n̂|).
    double modulus(double r) const override { return mInput->modulus(r) + 2.0 * double(mDmax); }
    double lipschitz() const override
    {
        const double a = mG.bandwidth > 0 ? mG.bandwidth : mG.frequency / 2;
        const double f = std::max({mG.frequency, mBlend.frequency, mSkeletonParams ? mDir.maxFrequency() : 0.0});
        return mInput->lipschitz() +
               double(mDmax) * (6.0 / double(mR > 0 ? std::min(mR, mRmax) : mRmax) + 2.0 * M_PI * (f + a));
    }

    static float falloff(double R, double A) { return float(R > 0 ? R : 12.0 * A); }
    // Saturated noise moves the surface by exactly A: s = D (1 - s/R)⁶ at s = A.
    static float intensity(float A, float R)
    {
        return A > 0 ? A / float(std::pow(1.0 - double(A) / double(R), 6.0)) : 0.0f;
    }
    bool exact() const override { return false; }

private:
    struct Work
    {
        alignas(64) float f[kMaxBatch], gx[kMaxBatch], gy[kMaxBatch], gz[kMaxBatch];
        alignas(64) float ox[kMaxBatch], oy[kMaxBatch], oz[kMaxBatch], iso[kMaxBatch];
        alignas(64) float k[kMaxBatch], n[kMaxBatch], scale[kMaxBatch], d[kMaxBatch];
        alignas(64) float h[3][kMaxBatch];
        alignas(64) float hc[3][3][kMaxBatch]; // Hessian columns (curvature frames)
        int idx[kMaxBatch];
    };

    void eval(const Batch& b, float* out, float* id) const
    {
        if (id) mInput->evalIdBatch(b, out, id);
        else mInput->evalBatch(b, out);
        // Points in the detail band |f| < R (the field is unchanged beyond it).
        auto w = std::make_unique<Work>(); // ~80 KB: too big for a worker's stack
        BatchBuffer p;
        int m = 0;
        for (int i = 0; i < b.n; ++i) {
            if (std::abs(out[i]) < mRmax) {
                w->idx[m] = i;
                p.x[m] = b.x[i];
                p.y[m] = b.y[i];
                p.z[m] = b.z[i];
                w->f[m] = out[i];
                ++m;
            }
        }
        if (m == 0) return;
        p.n = m;
        p.center = b.center;
        p.radius = b.radius;
        p.band = std::max(b.band, mRmax + 2.0f * mH);
        p.reach = std::max(b.reach, mRmax + 2.0f * mH);
        const Batch pv = p.view();
        const bool curvature = mDir.kind == DirectionKind::Curvature && !mG.isotropic;
        const float h = curvature ? 2.0f * mH : mH;
        mFrame->gradientBatch(pv, h, w->gx, w->gy, w->gz);
        if (curvature) hessian(pv, h, *w);
        BatchBuffer s; // projected points p_S
        for (int j = 0; j < m; ++j) {
            const float len = std::sqrt(w->gx[j] * w->gx[j] + w->gy[j] * w->gy[j] + w->gz[j] * w->gz[j]);
            const float inv = 1.0f / std::max(len, 1e-6f);
            const Vec3f n(w->gx[j] * inv, w->gy[j] * inv, w->gz[j] * inv);
            // Frame (n, t, b) from W (gabor §3): b = n ∧ W, t = b ∧ n. With parameters along the
            // skeleton, W and their values at p come from one pass over the primitives.
            SkeletonSample at;
            if (mSkeletonParams) at = skeletonAt(Vec3d(p.x[j], p.y[j], p.z[j]), true);
            Vec3f W = mSkeletonParams ? at.W : direction(j, pv, *w);
            Vec3f bb = n.cross(W);
            const float wl = W.length(), bl = bb.length();
            // Singularities: W ∥ n (or W = 0); curvature frames at umbilics (set in hessian).
            float c = curvature ? w->iso[j] : smoothstep(0.05f, 0.25f, wl > 1e-9f ? bl / wl : 0.0f) *
                                                  smoothstep(0.0f, 0.05f, wl);
            if (mG.isotropic) c = 0.0f;
            Vec3f t(0.0f), bn(0.0f);
            if (bl > 1e-9f) {
                bn = bb / bl;
                t = bn.cross(n);
            }
            // Shape parameters at p: the skeleton's there (or the stage's), blended by the
            // mask's weight there.
            float A = mA, R = mR, D = mD, cosA = mCosA, sinA = mSinA, cosT = mCosT, sinT = mSinT;
            float baseTilt = float(mG.tiltDeg);
            if (mSkeletonParams) {
                A = float(at.amplitude);
                R = falloff(mG.falloff, A);
                D = intensity(A, R);
                baseTilt = float(at.tilt);
                const float al = float(at.tilt * M_PI / 180);
                cosA = std::cos(al);
                sinA = std::sin(al);
            }
            const float wp = mMask ? (*mMask)(p.x[j], p.y[j], p.z[j]) : 0.0f;
            if (mMask) {
                const float A0 = A, R0 = R;
                A = lerp(A0, float(mBlend.gaborAmplitude), wp);
                R = lerp(R0, falloff(mBlend.falloff, mBlend.gaborAmplitude), wp);
                D = intensity(A, R);
                const float al = float(lerp(baseTilt, float(mBlend.tiltDeg), wp) * M_PI / 180);
                const float th = float(lerp(float(mG.tiltAzimuthDeg), float(mBlend.tiltAzimuthDeg), wp) * M_PI / 180);
                cosA = std::cos(al);
                sinA = std::sin(al);
                cosT = std::cos(th);
                sinT = std::sin(th);
            }
            w->d[j] = D;
            // Isotropic share and the noise's scale (independent blends lose variance).
            float iso = 0.0f, keep = c;
            if (mG.isotropic) {
                iso = 1.0f;
                keep = 1.0f;
            } else if (mSingular == Singular::Isotropic) {
                iso = 1.0f - c;
                keep = 1.0f / std::sqrt(c * c + iso * iso);
            }
            w->iso[j] = iso;
            w->scale[j] = keep;
            // Projection direction v_{α,θ} = cos α n + sin α (cos θ t + sin θ b) (gabor §4);
            // without a frame the tilt has no azimuth: project along n.
            Vec3f v = n;
            if (sinA != 0.0f && bl > 1e-9f) v = n * cosA + (t * cosT + bn * sinT) * sinA;
            const float cosv = std::max(v.dot(n), 0.1f);
            const float dist = w->f[j] / cosv; // signed, along v
            s.x[j] = p.x[j] - dist * v[0];
            s.y[j] = p.y[j] - dist * v[1];
            s.z[j] = p.z[j] - dist * v[2];
            const float r = std::abs(dist) / R;
            const float k = r < 1.0f ? (1.0f - r) : 0.0f;
            const float k2 = k * k;
            w->k[j] = k2 * k2 * k2 * std::min(len, 1.0f);
            // Noise parameters at p_S: orientation (doubled angles: ω and ω + 180° are the
            // same noise) and frequency (the direction's length scales the base frequency).
            float cw = mCosW, sw = mSinW, fscale = 1.0f;
            if (mSkeletonParams) {
                fscale = float(skeletonAt(Vec3d(s.x[j], s.y[j], s.z[j]), true).frequency / mG.frequency);
            }
            if (mMask) {
                const float ws = (*mMask)(s.x[j], s.y[j], s.z[j]);
                const double w0 = mG.orientationDeg * M_PI / 90.0, w1 = mBlend.orientationDeg * M_PI / 90.0;
                const float c2 = lerp(float(std::cos(w0)), float(std::cos(w1)), ws);
                const float s2 = lerp(float(std::sin(w0)), float(std::sin(w1)), ws);
                const float half = 0.5f * std::atan2(s2, c2);
                cw = std::cos(half);
                sw = std::sin(half);
                if (mBlend.frequency > 0) fscale = lerp(fscale, float(mBlend.frequency / mG.frequency), ws);
            }
            const Vec3f o = (t * cw + bn * sw) * fscale;
            w->ox[j] = o[0];
            w->oy[j] = o[1];
            w->oz[j] = o[2];
            w->gx[j] = n[0];
            w->gy[j] = n[1];
            w->gz[j] = n[2];
        }
        Vec3f lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
        for (int j = 0; j < m; ++j) {
            lo = minComponent(lo, Vec3f(s.x[j], s.y[j], s.z[j]));
            hi = maxComponent(hi, Vec3f(s.x[j], s.y[j], s.z[j]));
        }
        std::vector<GaborImpulse> imp;
        imp.reserve(256);
        mNoise.impulses(lo, hi, imp);
        mNoise.eval(imp, m, s.x, s.y, s.z, w->ox, w->oy, w->oz, w->gx, w->gy, w->gz, w->iso, w->n);
        for (int j = 0; j < m; ++j) {
            // D(noise): a bump for positive noise (the field decreases), bounded by D.
            const float nn = w->n[j] * mInvSigma * w->scale[j];
            out[w->idx[j]] = w->f[j] - w->d[j] * std::tanh(0.5f * nn) * w->k[j];
        }
    }

    // W at the points: the axis, the skeleton's weighted direction, or (curvature) the
    // direction of largest |κ| computed in hessian().
    Vec3f direction(int j, const Batch& b, const Work& w) const
    {
        switch (mDir.kind) {
        case DirectionKind::Axis: return mAxis;
        case DirectionKind::Skeleton: return skeletonAt(Vec3d(b.x[j], b.y[j], b.z[j]), false).W;
        case DirectionKind::Curvature:
            return Vec3f(w.ox[j], w.oy[j], w.oz[j]);
        }
        return mAxis;
    }

    // Principal direction of largest |κ| from the Hessian (second differences at step h):
    // W into ox/oy/oz and the anisotropy weight into iso (0 at umbilics and flats).
    void hessian(const Batch& b, float h, Work& w) const
    {
        // H from central differences of the gradient (a grid samples its gradient grid:
        // six gradient lookups instead of eighteen values), symmetrised.
        alignas(64) float gp[3][kMaxBatch], gm[3][kMaxBatch];
        alignas(64) float diag[3][kMaxBatch];
        float* off[3] = {w.h[0], w.h[1], w.h[2]}; // xy, xz, yz
        auto& hc = w.hc;
        const float inv = 0.5f / h;
        for (int a = 0; a < 3; ++a) {
            const float s[3] = {a == 0 ? h : 0.0f, a == 1 ? h : 0.0f, a == 2 ? h : 0.0f};
            BatchBuffer q;
            for (int sign = 1; sign >= -1; sign -= 2) {
                for (int i = 0; i < b.n; ++i) {
                    q.x[i] = b.x[i] + float(sign) * s[0];
                    q.y[i] = b.y[i] + float(sign) * s[1];
                    q.z[i] = b.z[i] + float(sign) * s[2];
                }
                q.n = b.n;
                q.center = b.center;
                q.radius = b.radius + h;
                q.band = b.band;
                q.reach = b.reach;
                float(*g)[kMaxBatch] = sign > 0 ? gp : gm;
                mFrame->gradientBatch(q.view(), mH, g[0], g[1], g[2]);
            }
            // Column a of H: ∂g/∂x_a.
            for (int c = 0; c < 3; ++c)
                for (int i = 0; i < b.n; ++i) hc[a][c][i] = (gp[c][i] - gm[c][i]) * inv;
        }
        for (int i = 0; i < b.n; ++i) {
            diag[0][i] = hc[0][0][i];
            diag[1][i] = hc[1][1][i];
            diag[2][i] = hc[2][2][i];
            off[0][i] = 0.5f * (hc[0][1][i] + hc[1][0][i]);
            off[1][i] = 0.5f * (hc[0][2][i] + hc[2][0][i]);
            off[2][i] = 0.5f * (hc[1][2][i] + hc[2][1][i]);
        }
        const float k0 = float(0.05 * mG.frequency); // curvature below this counts as flat
        for (int i = 0; i < b.n; ++i) {
            Vec3f n(w.gx[i], w.gy[i], w.gz[i]);
            const float len = n.length();
            if (len < 1e-6f) {
                w.ox[i] = w.oy[i] = w.oz[i] = 0.0f;
                w.iso[i] = 0.0f;
                continue;
            }
            n /= len;
            const Vec3f e1 = (std::abs(n[0]) < 0.9f ? Vec3f(1, 0, 0) : Vec3f(0, 1, 0)).cross(n).unitSafe();
            const Vec3f e2 = n.cross(e1);
            auto H = [&](const Vec3f& x, const Vec3f& y) {
                return x[0] * (diag[0][i] * y[0] + off[0][i] * y[1] + off[1][i] * y[2]) +
                       x[1] * (off[0][i] * y[0] + diag[1][i] * y[1] + off[2][i] * y[2]) +
                       x[2] * (off[1][i] * y[0] + off[2][i] * y[1] + diag[2][i] * y[2]);
            };
            const float a = H(e1, e1) / len, c = H(e1, e2) / len, d = H(e2, e2) / len;
            const float mean = 0.5f * (a + d), rad = std::sqrt(0.25f * (a - d) * (a - d) + c * c);
            const float k1 = mean + rad, k2 = mean - rad;
            float phi = 0.5f * std::atan2(2.0f * c, a - d); // direction of k1
            if (std::abs(k2) > std::abs(k1)) phi += float(M_PI / 2);
            const Vec3f W = e1 * std::cos(phi) + e2 * std::sin(phi);
            w.ox[i] = W[0];
            w.oy[i] = W[1];
            w.oz[i] = W[2];
            w.iso[i] = smoothstep(0.1f, 0.3f, (k1 - k2) / (std::abs(k1) + std::abs(k2) + k0));
        }
    }

    // The skeleton at q: W = Σ f_i S_i (gabor §3), and with @a values its parameters
    // (Σ f_i v_i + (1 − Σ f_i)⁺ v) / (Σ f_i + (1 − Σ f_i)⁺), v_i the primitive's value at its
    // point nearest q (or the stage's own v). The stage's values weigh 1 − Σ f_i where that is
    // positive: continuous at the edge of the skeleton's reach (a ratio alone would jump there).
    struct SkeletonSample
    {
        Vec3f W{0.0f};
        double amplitude = 0, frequency = 0, tilt = 0;
    };
    SkeletonSample skeletonAt(const Vec3d& q, bool values) const
    {
        Vec3d W(0.0);
        double sw = 0, sa = 0, sf = 0, st = 0;
        for (const Primitive& pr : mDir.primitives) {
            double bary[3];
            const double d2 = nearest(pr, q, bary).lengthSqr() / (pr.radius * pr.radius);
            if (d2 >= 1.0) continue;
            const double k = 1.0 - d2, f = pr.weight * k * k * k;
            W += pr.direction * f;
            if (!values) continue;
            auto at = [&](const std::array<double, 3>& v, double own) {
                if (std::isnan(v[0])) return own;
                double x = 0;
                for (int c = 0; c < pr.count; ++c) x += bary[c] * v[size_t(c)];
                return x;
            };
            sw += f;
            sa += f * at(pr.amplitude, mG.amplitude);
            sf += f * at(pr.frequency, mG.frequency);
            st += f * at(pr.tilt, mG.tiltDeg);
        }
        SkeletonSample r;
        r.W = Vec3f(float(W[0]), float(W[1]), float(W[2]));
        if (values) {
            const double own = std::max(0.0, 1.0 - sw), all = sw + own;
            r.amplitude = (sa + own * mG.amplitude) / all;
            r.frequency = (sf + own * mG.frequency) / all;
            r.tilt = (st + own * mG.tiltDeg) / all;
        }
        return r;
    }

    FieldPtr mInput, mFrame;
    GaborParams mG;
    bool mSkeletonParams = false;
    DirectionField mDir;
    GaborNoise mNoise;
    float mH;
    float mA = 0, mR = 1, mD = 0, mRmax = 1, mDmax = 0, mAmax = 0;
    BlendParams mBlend;
    std::unique_ptr<MaskSampler> mMask;
    float mCosA = 1, mSinA = 0, mCosT = 1, mSinT = 0, mCosW = 1, mSinW = 0;
    float mInvSigma = 1;
    Singular mSingular = Singular::Cancel;
    Vec3f mAxis;
};

} // namespace

namespace {

Vec3d vec3(const nlohmann::json& v, const std::string& what)
{
    if (!v.is_array() || v.size() != 3) fail<ValueError>("skeleton: ", what, " must be [x, y, z]");
    Vec3d r;
    for (int k = 0; k < 3; ++k) {
        if (!v[size_t(k)].is_number()) fail<ValueError>("skeleton: ", what, " must be [x, y, z]");
        r[k] = v[size_t(k)].get<double>();
        if (!std::isfinite(r[k])) fail<ValueError>("skeleton: ", what, " must be finite");
    }
    return r;
}

double number(const nlohmann::json& v, const std::string& what)
{
    if (!v.is_number() || !std::isfinite(v.get<double>())) fail<ValueError>("skeleton: ", what, " must be a number");
    return v.get<double>();
}

// A parameter given once or per vertex (n of them): its n values.
std::vector<double> perVertex(const nlohmann::json& v, size_t n, const std::string& what)
{
    if (v.is_number()) return std::vector<double>(n, number(v, what));
    if (!v.is_array() || v.size() != n) {
        fail<ValueError>("skeleton: ", what, " must be a number or ", n, " numbers (one per vertex)");
    }
    std::vector<double> r;
    for (size_t k = 0; k < n; ++k) r.push_back(number(v[k], what + "[" + std::to_string(k) + "]"));
    return r;
}

} // namespace

DirectionField DirectionField::fromSkeletonJson(const nlohmann::json& j)
{
    DirectionField d;
    d.kind = DirectionKind::Skeleton;
    static const std::map<std::string, std::vector<std::string>> keys = {
        {"segments", {"a", "b", "radius", "weight", "amplitude", "frequency", "tilt"}},
        {"polylines", {"points", "closed", "radius", "weight", "amplitude", "frequency", "tilt"}},
        {"points", {"p", "radius", "weight", "direction", "amplitude", "frequency", "tilt"}},
        {"triangles", {"a", "b", "c", "radius", "weight", "direction", "amplitude", "frequency", "tilt"}}};
    const std::string expected = "expected {\"segments\" | \"polylines\" | \"points\" | \"triangles\": [...]}";
    if (!j.is_object()) fail<ValueError>("skeleton: ", expected);
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (!keys.count(it.key())) fail<ValueError>("skeleton: unknown key \"", it.key(), "\" (", expected, ")");
        if (!it.value().is_array()) fail<ValueError>("skeleton: ", it.key(), " must be a list");
    }
    for (const auto& [kind, allowed] : keys) {
        if (!j.contains(kind)) continue;
        const auto& list = j.at(kind);
        for (size_t n = 0; n < list.size(); ++n) {
            const auto& e = list[n];
            const std::string at = kind + "[" + std::to_string(n) + "]";
            if (!e.is_object()) fail<ValueError>("skeleton: ", at, " must be an object");
            for (auto it = e.begin(); it != e.end(); ++it) {
                if (std::find(allowed.begin(), allowed.end(), it.key()) == allowed.end()) {
                    std::string list;
                    for (const auto& k : allowed) list += (list.empty() ? "" : ", ") + k;
                    fail<ValueError>("skeleton: ", at, ": unknown key \"", it.key(), "\" (", kind, " take ", list, ")");
                }
            }
            auto need = [&](const char* key) -> const nlohmann::json& {
                if (!e.contains(key)) fail<ValueError>("skeleton: ", at, ".", key, " is required");
                return e.at(key);
            };
            Primitive proto;
            proto.radius = number(need("radius"), at + ".radius");
            proto.weight = e.contains("weight") ? number(e.at("weight"), at + ".weight") : 1.0;
            require(proto.radius > 0, "skeleton", (at + ".radius").c_str(), "> 0", proto.radius);
            require(proto.weight > 0, "skeleton", (at + ".weight").c_str(), "> 0", proto.weight);
            std::vector<Vec3d> vs;
            if (kind == "segments") vs = {vec3(need("a"), at + ".a"), vec3(need("b"), at + ".b")};
            if (kind == "triangles") vs = {vec3(need("a"), at + ".a"), vec3(need("b"), at + ".b"), vec3(need("c"), at + ".c")};
            if (kind == "points") vs = {vec3(need("p"), at + ".p")};
            bool closed = false;
            if (kind == "polylines") {
                const auto& pts = need("points");
                if (!pts.is_array() || pts.size() < 2) fail<ValueError>("skeleton: ", at, ".points must hold at least 2 points");
                for (size_t k = 0; k < pts.size(); ++k) vs.push_back(vec3(pts[k], at + ".points[" + std::to_string(k) + "]"));
                if (e.contains("closed")) {
                    if (!e.at("closed").is_boolean()) fail<ValueError>("skeleton: ", at, ".closed must be true or false");
                    closed = e.at("closed").get<bool>();
                }
            }
            // Parameters per vertex of the whole primitive (a polyline: per point).
            std::vector<double> amp, freq, tilt;
            if (e.contains("amplitude")) amp = perVertex(e.at("amplitude"), vs.size(), at + ".amplitude");
            if (e.contains("frequency")) freq = perVertex(e.at("frequency"), vs.size(), at + ".frequency");
            if (e.contains("tilt")) tilt = perVertex(e.at("tilt"), vs.size(), at + ".tilt");
            for (double a : amp) require(a >= 0, "skeleton", (at + ".amplitude").c_str(), ">= 0 m", a);
            for (double f : freq) require(f > 0, "skeleton", (at + ".frequency").c_str(), "> 0 cycles/m", f);
            for (double t : tilt) require(t >= 0 && t <= 75, "skeleton", (at + ".tilt").c_str(), "in [0, 75] degrees", t);
            auto setParams = [&](Primitive& pr, const std::vector<size_t>& idx) {
                for (size_t c = 0; c < idx.size(); ++c) {
                    if (!amp.empty()) pr.amplitude[c] = amp[idx[c]];
                    if (!freq.empty()) pr.frequency[c] = freq[idx[c]];
                    if (!tilt.empty()) pr.tilt[c] = tilt[idx[c]];
                }
            };
            Vec3d given(0, 0, 1);
            if (e.contains("direction")) {
                given = vec3(e.at("direction"), at + ".direction");
                require(given.length() > 0, "skeleton", (at + ".direction").c_str(), "non-zero", given.length());
                given.normalize();
            }
            if (kind == "points") {
                Primitive pr = proto;
                pr.count = 1;
                pr.v[0] = vs[0];
                pr.direction = given;
                setParams(pr, {0});
                d.primitives.push_back(pr);
            } else if (kind == "triangles") {
                Primitive pr = proto;
                pr.count = 3;
                for (int c = 0; c < 3; ++c) pr.v[c] = vs[size_t(c)];
                Vec3d nrm = (vs[1] - vs[0]).cross(vs[2] - vs[0]);
                require(nrm.length() > 0, "skeleton", (at + " area").c_str(), "> 0 (a, b, c not collinear)", nrm.length());
                nrm.normalize();
                // A vector of its plane: the direction given, projected; by default a → b.
                Vec3d s = e.contains("direction") ? given - nrm * given.dot(nrm) : vs[1] - vs[0];
                require(s.length() > 1e-9, "skeleton", (at + ".direction").c_str(), "not normal to the triangle", s.length());
                s.normalize();
                pr.direction = s;
                setParams(pr, {0, 1, 2});
                d.primitives.push_back(pr);
            } else {
                // A segment, or a polyline's segments (closed: back to the first point).
                const size_t count = vs.size() - 1 + (closed ? 1 : 0);
                for (size_t k = 0; k < count; ++k) {
                    const size_t k1 = (k + 1) % vs.size();
                    Primitive pr = proto;
                    pr.count = 2;
                    pr.v[0] = vs[k];
                    pr.v[1] = vs[k1];
                    const Vec3d ab = vs[k1] - vs[k];
                    require(ab.length() > 0, "skeleton", (at + " segment length").c_str(), "> 0 (repeated point)", ab.length());
                    pr.direction = ab / ab.length();
                    setParams(pr, {k, k1});
                    d.primitives.push_back(pr);
                }
            }
        }
    }
    if (d.primitives.empty()) fail<ValueError>("skeleton: no primitives (", expected, ")");
    return d;
}

bool DirectionField::hasParameters() const
{
    for (const Primitive& p : primitives) {
        if (!std::isnan(p.amplitude[0]) || !std::isnan(p.frequency[0]) || !std::isnan(p.tilt[0])) return true;
    }
    return false;
}

namespace {

// The largest value a primitive carries at a vertex (0 when none carries one).
double largest(const std::vector<Primitive>& primitives, std::array<double, 3> Primitive::*member)
{
    double m = 0;
    for (const Primitive& p : primitives)
        for (int c = 0; c < p.count; ++c)
            if (!std::isnan((p.*member)[size_t(c)])) m = std::max(m, (p.*member)[size_t(c)]);
    return m;
}

} // namespace

double DirectionField::maxAmplitude() const { return largest(primitives, &Primitive::amplitude); }

double DirectionField::maxFrequency() const { return largest(primitives, &Primitive::frequency); }

void DetailParams::validate(double voxelSize) const
{
    if (gabor.frequency == 0 && resolved().gabor.frequency > 0) return resolved().validate(voxelSize);
    const char* op = "detail";
    require(std::isfinite(warp.amplitude) && warp.amplitude >= 0, op, "warp amplitude", ">= 0 m",
            warp.amplitude);
    if (warp.amplitude > 0) {
        require(std::isfinite(warp.scale) && warp.scale > 0, op, "warp scale", "> 0 m", warp.scale);
        require(warp.octaves >= 1 && warp.octaves <= 12, op, "warp octaves", "in [1, 12]",
                warp.octaves);
        require(std::isfinite(warp.sharpness) && warp.sharpness >= 1 && warp.sharpness <= 64, op,
                "warp sharpness", "in [1, 64]", warp.sharpness);
    }
    const GaborParams& g = gabor;
    require(std::isfinite(g.amplitude) && g.amplitude >= 0, op, "gabor amplitude", ">= 0 m",
            g.amplitude);
    if (blend) {
        const BlendParams& b = *blend;
        require(std::isfinite(b.warpAmplitude) && b.warpAmplitude >= 0, op, "blend warp amplitude",
                ">= 0 m", b.warpAmplitude);
        require(std::isfinite(b.gaborAmplitude) && b.gaborAmplitude >= 0, op,
                "blend gabor amplitude", ">= 0 m", b.gaborAmplitude);
        require(std::isfinite(b.frequency) && b.frequency >= 0, op, "blend gabor frequency",
                ">= 0 cycles/m", b.frequency);
        const double a = g.bandwidth > 0 ? g.bandwidth : g.frequency / 2;
        const double nyquist = 1.0 / (2.0 * voxelSize);
        if (b.gaborAmplitude > 0 && b.frequency + a > nyquist) {
            fail<ValueError>("detail: blend gabor frequency ", b.frequency, " + bandwidth ", a,
                             " cycles/m exceeds the voxel Nyquist limit 1/(2·voxel) = ", nyquist,
                             " cycles/m (voxel ", voxelSize, " m)");
        }
        const double R = b.falloff > 0 ? b.falloff : 12.0 * b.gaborAmplitude;
        require(std::isfinite(b.falloff) && b.falloff >= 0 && R >= 1.5 * b.gaborAmplitude, op,
                "blend gabor falloff R", ">= 1.5 x amplitude (0 = 12 x amplitude)", b.falloff);
        require(std::isfinite(b.tiltDeg) && b.tiltDeg >= 0 && b.tiltDeg <= 75, op, "blend tilt",
                "in [0, 75] degrees", b.tiltDeg);
        require(std::isfinite(b.orientationDeg) && std::isfinite(b.tiltAzimuthDeg), op,
                "blend angles", "finite", b.orientationDeg);
        if (b.warpAmplitude > 0 && warp.amplitude <= 0) {
            // The relief's scale and octaves come from the base set.
            require(std::isfinite(warp.scale) && warp.scale > 0, op, "warp scale", "> 0 m",
                    warp.scale);
        }
    }
    if (maxGabor() > 0) {
        const double a = g.bandwidth > 0 ? g.bandwidth : g.frequency / 2;
        const double nyquist = 1.0 / (2.0 * voxelSize);
        require(std::isfinite(g.frequency) && g.frequency > 0, op, "gabor frequency",
                "> 0 cycles/m", g.frequency);
        require(std::isfinite(g.bandwidth) && g.bandwidth >= 0, op, "gabor bandwidth", ">= 0 (1/m)",
                g.bandwidth);
        if (g.frequency + a > nyquist) {
            fail<ValueError>("detail: gabor frequency ", g.frequency, " + bandwidth ", a,
                             " cycles/m exceeds the voxel Nyquist limit 1/(2·voxel) = ", nyquist,
                             " cycles/m (voxel ", voxelSize, " m): lower the frequency or the "
                             "voxel size");
        }
        require(std::isfinite(g.impulses) && g.impulses >= 1 && g.impulses <= 256, op,
                "gabor impulses", "in [1, 256] per kernel", g.impulses);
        const double R = g.falloff > 0 ? g.falloff : 12.0 * g.amplitude;
        require(std::isfinite(g.falloff) && g.falloff >= 0 && R >= 1.5 * g.amplitude, op,
                "gabor falloff R", ">= 1.5 x amplitude (0 = 12 x amplitude)", g.falloff);
        require(std::isfinite(g.tiltDeg) && g.tiltDeg >= 0 && g.tiltDeg <= 75, op, "tilt",
                "in [0, 75] degrees", g.tiltDeg);
        require(std::isfinite(g.tiltAzimuthDeg) && std::isfinite(g.orientationDeg), op,
                "angles", "finite", g.orientationDeg);
        // Kernels several times wider than a voxel, or the table of impulses explodes.
        require(a >= 1e-3, op, "gabor bandwidth", ">= 0.001 (1/m)", a);
    }
    if (direction.kind == DirectionKind::Axis) {
        require(direction.axis.length() > 0 && std::isfinite(direction.axis.length()), op,
                "direction axis", "non-zero", direction.axis.length());
    }
    if (direction.kind == DirectionKind::Skeleton && direction.primitives.empty()) {
        fail<ValueError>("detail: the skeleton direction field needs primitives");
    }
    if (direction.kind == DirectionKind::Skeleton && direction.hasParameters()) {
        // Parameters along the skeleton vary the amplitude and frequency the stage's set.
        const double a = g.bandwidth > 0 ? g.bandwidth : g.frequency / 2;
        const double nyquist = 1.0 / (2.0 * voxelSize);
        if (direction.maxFrequency() + a > nyquist) {
            fail<ValueError>("detail: skeleton frequency ", direction.maxFrequency(), " + bandwidth ", a,
                             " cycles/m exceeds the voxel Nyquist limit 1/(2·voxel) = ", nyquist,
                             " cycles/m (voxel ", voxelSize, " m)");
        }
        if (g.falloff > 0) {
            require(g.falloff >= 1.5 * direction.maxAmplitude(), op, "gabor falloff R",
                    ">= 1.5 x the skeleton's largest amplitude", g.falloff);
        }
    }
}

double DetailParams::maxWarp() const
{
    return std::max(warp.amplitude, blend ? blend->warpAmplitude : 0.0);
}

double DetailParams::maxGabor() const
{
    return std::max({gabor.amplitude, blend ? blend->gaborAmplitude : 0.0,
                     direction.kind == DirectionKind::Skeleton ? direction.maxAmplitude() : 0.0});
}

double DetailParams::reach(double halfWidthMetres) const
{
    // Band voxels of the result lie within the band + the displacement of the input surface
    // (the surface moves by at most A_warp + A_gabor), plus the renormalisation's one-voxel
    // stencil (taken as half the band: the step is not known here).
    return 1.5 * halfWidthMetres + maxWarp() + maxGabor();
}

DetailParams DetailParams::resolved() const
{
    DetailParams r = *this;
    // (With no amplitude of its own, the skeleton's largest sets the default frequency.)
    const double a = r.gabor.amplitude > 0 ? r.gabor.amplitude
                   : r.direction.kind == DirectionKind::Skeleton ? r.direction.maxAmplitude() : 0.0;
    if (r.gabor.frequency == 0 && a > 0) {
        r.gabor.frequency = 1.0 / (kDefaultWavelengthPerAmplitude * a);
    }
    return r;
}

FieldPtr detailField(FieldPtr input, const DetailParams& params, double gradientStep)
{
    const DetailParams p = params.resolved();
    if (!input) fail<ValueError>("detail: the input is required");
    FieldPtr f = input;
    const BlendParams* blend = p.blend && p.blendMask ? p.blend.get() : nullptr;
    const double warpMax = std::max(p.warp.amplitude, blend ? blend->warpAmplitude : 0.0);
    if (warpMax > 0) {
        const BBoxd bb = input->bounds();
        if (!isBounded(bb)) fail<ValueError>("detail: the input must be bounded");
        float lo = float(std::min({bb.min()[0], bb.min()[1], bb.min()[2]}));
        float hi = float(std::max({bb.max()[0], bb.max()[1], bb.max()[2]}));
        ReliefParams r = p.warp;
        r.amplitude = warpMax;
        f = std::make_shared<GradientWarp>(input, r, p.seed, float(gradientStep), lo - 1, hi + 1,
                                           float(p.warp.amplitude),
                                           float(blend ? blend->warpAmplitude : p.warp.amplitude),
                                           blend ? p.blendMask : nullptr);
    }
    const bool gabor = p.gabor.amplitude > 0 || (blend && blend->gaborAmplitude > 0) ||
                       (p.direction.kind == DirectionKind::Skeleton && p.direction.maxAmplitude() > 0);
    if (gabor) {
        f = std::make_shared<GaborDetail>(f, input, p.gabor, p.direction, float(gradientStep),
                                          blend, blend ? p.blendMask : nullptr);
    }
    return f;
}

BakeResult detailLevelSet(openvdb::FloatGrid::ConstPtr grid, const DetailParams& params,
                          const BakeSettings& settings, openvdb::util::NullInterrupter* interrupt,
                          openvdb::FloatGrid::ConstPtr* widened)
{
    const DetailParams p = params.resolved();
    if (!grid) fail<ValueError>("detail: the input grid is null");
    requireLevelSet(*grid, "detail input");
    const double dx = grid->voxelSize()[0];
    p.validate(std::max(settings.voxelSize, dx));
    if (p.blend && !p.blendMask) {
        fail<ValueError>("detail: blend parameters need a blend mask grid (weights in [0, 1])");
    }
    // Without detail the input's own band is all the bake reads (a plain resample).
    const bool none = p.maxWarp() <= 0 && p.maxGabor() <= 0;
    // The input's band is widened layer by layer to reach(): refuse amplitudes that would
    // sweep hundreds of voxel layers (minutes and gigabytes) before the bake's own estimate.
    const double widen = (p.reach(settings.halfWidth * settings.voxelSize) -
                          double(grid->background())) / dx;
    if (!none && widen > kMaxWidenVoxels) {
        fail<ValueError>("detail: amplitudes (warp ", p.maxWarp(), " m, gabor ", p.maxGabor(),
                         " m) need the input's band widened by ", std::ceil(widen),
                         " voxels, at most ", kMaxWidenVoxels, " at voxel size ", dx,
                         " m: use smaller amplitudes or a coarser input");
    }
    const openvdb::FloatGrid::ConstPtr wide =
        widenBand(grid, none ? 0.0 : p.reach(settings.halfWidth * settings.voxelSize),
                  settings.maxMemoryBytes);
    if (widened) *widened = wide;
    const openvdb::math::Transform& xf = grid->transform();
    const bool sameVoxels = std::abs(settings.voxelSize - dx) < 1e-9 * dx &&
                            xf.indexToWorld(openvdb::Vec3d(0.0)).length() < 1e-9 * dx &&
                            xf.isLinear() && xf.hasUniformScale();
    const FieldPtr input = levelSetField(wide);
    // The warp and the frames read the input's gradient at every point: on the input's own
    // voxels levelSetField takes it on the fly; elsewhere it samples a gradient grid, built
    // now with every thread.
    if (!none && !sameVoxels) input->prepareGradient();
    FieldPtr f = detailField(input, p, dx);
    if (none) return bake(*f, settings, interrupt);
    BakeSettings s = settings;
    if (sameVoxels) {
        // Candidate voxels: those within the band plus the displacement of the input surface
        // (the surface moves by at most A) plus one voxel (the first-order renormalisation's
        // error; three voxels here added 3670 deep-side voxels of 13 M on the demo and 24 %
        // more evaluations), read off the widened input's distances; the rest of space only
        // holds bounds of the distance. Beyond the widened
        // band (|value| = its background) the input's distance and gradient are unknown:
        // those voxels stay out, voxel by voxel, with the input's sign (candidateSigns), or
        // the bounds there, divided by a steep warp gradient, would fake band voxels deep
        // inside. Only the mask's voxels and their neighbours are evaluated.
        const float limit = std::min(
            float(settings.halfWidth * dx + p.maxWarp() + p.maxGabor() + dx), wide->background());
        auto mask = openvdb::MaskGrid::create();
        mask->tree().topologyUnion(wide->tree());
        openvdb::tree::LeafManager<openvdb::MaskTree> leaves(mask->tree());
        leaves.foreach([&](openvdb::MaskTree::LeafNodeType& leaf, size_t) {
            const auto* in = wide->tree().probeConstLeaf(leaf.origin());
            openvdb::MaskTree::LeafNodeType::NodeMaskType keep;
            for (auto it = leaf.getValueMask().beginOn(); in && it; ++it) {
                if (std::abs(in->getValue(it.pos())) < limit) keep.setOn(it.pos());
            }
            leaf.setValueMask(keep);
        });
        openvdb::tools::pruneInactive(mask->tree());
        s.candidates = mask;
        s.candidateSigns = wide;
    }
    // The Gabor blob term bends the field along the normal (its slope there ranges over
    // 1 ± 6D/R): OpenVDB's LevelSetTracker restores |∇φ| = 1 across the band.
    if (p.maxGabor() > 0) s.trackerSteps = std::max(s.trackerSteps, kGaborTrackerSteps);
    return bake(*f, s, interrupt);
}

std::vector<openvdb::FloatGrid::Ptr>
carryAttributes(const openvdb::FloatGrid& input, const openvdb::FloatGrid& detailed,
                const std::vector<const openvdb::FloatGrid*>& ids,
                openvdb::util::NullInterrupter* interrupt)
{
    std::vector<openvdb::FloatGrid::Ptr> out;
    for (const openvdb::FloatGrid* g : ids) {
        if (!g) fail<ValueError>("detail: an attribute grid is null");
        auto o = openvdb::FloatGrid::create(g->background());
        o->setName(g->getName());
        o->setTransform(detailed.transform().copy());
        o->setGridClass(g->getGridClass());
        o->insertMeta(*g);
        o->tree().topologyUnion(detailed.tree());
        out.push_back(o);
    }
    if (out.empty()) return out;
    // The walk to the input surface is the same for every grid: done once per voxel, on the
    // first output's leaves; the others' leaves (same topology) are found by origin.
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(out[0]->tree());
    const double dx = input.voxelSize()[0];
    // Grids on the first one's voxels (block_id and material share them) reuse its search.
    std::vector<char> sameAsFirst(ids.size(), 0);
    for (size_t g = 1; g < ids.size(); ++g) {
        sameAsFirst[g] = ids[g]->transform() == ids[0]->transform() &&
                         ids[g]->tree().hasSameTopology(ids[0]->tree());
    }
    std::atomic<bool> stop{false};
    leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
        // Interrupted: the rest is skipped (the caller checks and throws).
        if (stop.load(std::memory_order_relaxed)) return;
        if (interrupt && interrupt->wasInterrupted()) {
            stop = true;
            return;
        }
        auto in = input.getConstAccessor();
        auto det = detailed.getConstAccessor();
        std::vector<openvdb::FloatGrid::ConstAccessor> id;
        std::vector<openvdb::FloatTree::LeafNodeType*> dst{&leaf};
        for (size_t g = 0; g < ids.size(); ++g) {
            id.push_back(ids[g]->getConstAccessor());
            if (g > 0) dst.push_back(out[g]->tree().probeLeaf(leaf.origin()));
        }
        for (auto it = leaf.beginValueOn(); it; ++it) {
            // First onto the detailed surface (within the displacement of the input's), along
            // the detailed level set's own gradient.
            const openvdb::Coord ijk = it.getCoord();
            const Vec3d gd(det.getValue(ijk.offsetBy(1, 0, 0)) - det.getValue(ijk.offsetBy(-1, 0, 0)),
                           det.getValue(ijk.offsetBy(0, 1, 0)) - det.getValue(ijk.offsetBy(0, -1, 0)),
                           det.getValue(ijk.offsetBy(0, 0, 1)) - det.getValue(ijk.offsetBy(0, 0, -1)));
            Vec3d q = detailed.indexToWorld(ijk);
            const double gdl = gd.length();
            if (gdl > 1e-9) q -= gd * (double(det.getValue(ijk)) / gdl);
            // Walk to the input surface along its gradient (values beyond the input's band
            // are clamped: a few steps bring the point into it). Where every sample is clamped
            // the gradient vanishes: step along the detailed surface's normal instead, by
            // the clamped value (towards the input surface, by its sign), and go on.
            for (int step = 0; step < 6; ++step) {
                const Vec3d i = input.worldToIndex(q);
                const float f = boxSample(in, i);
                if (std::abs(f) < 0.5 * dx) break; // on the input surface: no gradient needed
                const Vec3d g(boxSample(in, i + Vec3d(1, 0, 0)) - boxSample(in, i - Vec3d(1, 0, 0)),
                              boxSample(in, i + Vec3d(0, 1, 0)) - boxSample(in, i - Vec3d(0, 1, 0)),
                              boxSample(in, i + Vec3d(0, 0, 1)) - boxSample(in, i - Vec3d(0, 0, 1)));
                const double len = g.length();
                if (len >= 1e-9) q -= g * (double(f) / len);
                else if (gdl > 1e-9) q -= gd * (double(f) / gdl);
                else break;
            }
            bool found = false;
            openvdb::Coord nearest;
            for (size_t gi = 0; gi < ids.size(); ++gi) {
                // The nearest active id voxel (the surface point lies in the id band). An
                // active -1 is a value (bare terrain in block_id), not a hole: skipping it let
                // block ids bleed onto the terrain round every block, out of step with
                // 'material'.
                const openvdb::FloatGrid& grid = *ids[gi];
                if (gi > 0 && sameAsFirst[gi]) {
                    // Same voxels as the first grid: the same nearest voxel.
                    dst[gi]->setValueOnly(it.pos(), found ? id[gi].getValue(nearest)
                                                          : grid.background());
                    continue;
                }
                const openvdb::Coord c = openvdb::Coord::round(grid.worldToIndex(q));
                float v = grid.background();
                float best = std::numeric_limits<float>::max();
                // The voxel itself (nearly always, the point being on the input surface in
                // the id band): nothing is nearer.
                if (id[gi].probeValue(c, v)) {
                    best = 0.0f;
                    if (gi == 0) nearest = c;
                } else {
                    v = grid.background();
                }
                // Nearest first: the 3³ neighbourhood, then 5³ where the walk stopped short.
                for (int r = 1; r <= 2 && best == std::numeric_limits<float>::max(); ++r) {
                    for (int a = -r; a <= r; ++a)
                        for (int b = -r; b <= r; ++b)
                            for (int k = -r; k <= r; ++k) {
                                float w;
                                if (!id[gi].probeValue(c.offsetBy(a, b, k), w)) continue;
                                const float d2 = float(a * a + b * b + k * k);
                                if (d2 < best) {
                                    best = d2;
                                    v = w;
                                    if (gi == 0) nearest = c.offsetBy(a, b, k);
                                }
                            }
                }
                if (gi == 0) found = best != std::numeric_limits<float>::max();
                dst[gi]->setValueOnly(it.pos(), v);
            }
        }
    });
    return out;
}

openvdb::FloatGrid::Ptr carryAttribute(const openvdb::FloatGrid& input,
                                       const openvdb::FloatGrid& detailed,
                                       const openvdb::FloatGrid& ids)
{
    return carryAttributes(input, detailed, {&ids}).front();
}

} // namespace detail
} // namespace rockvdb
