// SPDX-License-Identifier: Apache-2.0
#include "Combinators.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Random.h>

#include <openvdb/math/Mat3.h>

#include <algorithm>
#include <cmath>

namespace rockvdb {

namespace {

class Csg final : public Field
{
public:
    Csg(CsgOp op, std::vector<FieldPtr> children, float r)
        : mOp(op), mChildren(std::move(children)), mR(r) {}

    void evalBatch(const Batch& b, float* out) const override { eval(b, out, nullptr); }

    void evalIdBatch(const Batch& b, float* out, float* id) const override { eval(b, out, id); }

    BBoxd bounds() const override
    {
        BBoxd bb = mChildren[0]->bounds();
        for (size_t c = 1; c < mChildren.size(); ++c) {
            const BBoxd cb = mChildren[c]->bounds();
            if (mOp == CsgOp::Union) {
                bb.expand(cb);
            } else if (mOp == CsgOp::Intersection) {
                bb = BBoxd(maxComponent(bb.min(), cb.min()), minComponent(bb.max(), cb.max()));
            }
        }
        // A smooth union adds at most R/6 of material; pad generously by R.
        if (mOp == CsgOp::Union && mR > 0 && isBounded(bb)) bb.expand(double(mR));
        return bb;
    }

    double lipschitz() const override
    {
        double l = 0;
        for (const auto& c : mChildren) l = std::max(l, c->lipschitz());
        return l;
    }

    // min, max and the smooth operators are 1-Lipschitz in (a, b) for the max norm.
    double modulus(double r) const override
    {
        double w = 0;
        for (const auto& c : mChildren) w = std::max(w, c->modulus(r));
        return w;
    }

    bool exact() const override
    {
        if (mR > 0) return false;
        for (const auto& c : mChildren) if (!c->exact()) return false;
        return true;
    }

private:
    // Can operand c be skipped for the whole batch? Only when its Lipschitz bound proves it
    // lies beyond the batch's band (plus the smooth blend's reach) at every point, where the
    // result is unchanged after the caller's clamping.
    bool skippable(const Field& c, const Batch& b, bool first) const
    {
        if (!std::isfinite(b.band) || !std::isfinite(b.radius)) return false;
        const float reach = b.band + mR * (7.0f / 6.0f);
        const float v = c.eval(Vec3d(b.center));
        const float spread = float(c.modulus(double(b.radius))) * 1.01f + 1e-5f;
        switch (mOp) {
        case CsgOp::Union: return v - spread >= reach;             // far outside c
        case CsgOp::Intersection: return v + spread <= -reach;     // deep inside c
        case CsgOp::Difference: return !first && v - spread >= reach; // far outside the cutter
        }
        return false;
    }

    void eval(const Batch& b, float* out, float* id) const
    {
        alignas(64) float tmp[kMaxBatch];
        alignas(64) float tmpId[kMaxBatch];
        bool started = false;
        for (size_t c = 0; c < mChildren.size(); ++c) {
            if (skippable(*mChildren[c], b, c == 0)) continue;
            if (!started) {
                if (id) mChildren[c]->evalIdBatch(b, out, id);
                else mChildren[c]->evalBatch(b, out);
                if (c > 0 && mOp == CsgOp::Difference) {
                    // Cannot happen (first operand is never skipped) but keep it total.
                    for (int i = 0; i < b.n; ++i) out[i] = -out[i];
                }
                started = true;
                continue;
            }
            if (id) {
                mChildren[c]->evalIdBatch(b, tmp, tmpId);
                if (mOp == CsgOp::Union) {
                    for (int i = 0; i < b.n; ++i) id[i] = tmp[i] < out[i] ? tmpId[i] : id[i];
                } else if (mOp == CsgOp::Intersection) {
                    for (int i = 0; i < b.n; ++i) id[i] = tmp[i] > out[i] ? tmpId[i] : id[i];
                }
            } else {
                mChildren[c]->evalBatch(b, tmp);
            }
            combine(b.n, out, tmp);
        }
        if (!started) {
            // Every operand is beyond the band: any value past it is equivalent.
            const float far = mOp == CsgOp::Intersection ? -(b.band + mR) : b.band + mR;
            std::fill(out, out + b.n, far);
            if (id) std::fill(id, id + b.n, kNoId);
        }
    }

    void combine(int n, float* __restrict out, const float* __restrict v) const
    {
        const float r = mR;
        switch (mOp) {
        case CsgOp::Union:
            if (r > 0) for (int i = 0; i < n; ++i) out[i] = smoothUnion(out[i], v[i], r);
            else for (int i = 0; i < n; ++i) out[i] = std::min(out[i], v[i]);
            break;
        case CsgOp::Intersection:
            if (r > 0) for (int i = 0; i < n; ++i) out[i] = smoothIntersection(out[i], v[i], r);
            else for (int i = 0; i < n; ++i) out[i] = std::max(out[i], v[i]);
            break;
        case CsgOp::Difference:
            if (r > 0) for (int i = 0; i < n; ++i) out[i] = smoothDifference(out[i], v[i], r);
            else for (int i = 0; i < n; ++i) out[i] = std::max(out[i], -v[i]);
            break;
        }
    }

    CsgOp mOp;
    std::vector<FieldPtr> mChildren;
    float mR;
};

class Transform final : public Field
{
public:
    Transform(FieldPtr child, const openvdb::math::Mat4d& m) : mChild(std::move(child)), mM(m)
    {
        const openvdb::math::Mat4d inv = m.inverse();
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 3; ++c) mInv[r][c] = float(inv(r, c));
        // Smallest singular value of the linear part = sqrt(min eigenvalue of MᵀM).
        const openvdb::math::Mat3d a = m.getMat3();
        openvdb::math::Mat3d q;
        Vec3d ev;
        openvdb::math::diagonalizeSymmetricMatrix(a.transpose() * a, q, ev);
        const double smin = std::sqrt(std::max(std::min({ev[0], ev[1], ev[2]}), 0.0));
        const double smax = std::sqrt(std::max(std::max({ev[0], ev[1], ev[2]}), 0.0));
        mScale = float(smin);
        mInvNorm = float(1.0 / std::max(smin, 1e-300));
        mRigidLike = smax - smin <= 1e-9 * smax;
    }

    void evalBatch(const Batch& b, float* out) const override
    {
        BatchBuffer local;
        toLocal(b, local);
        mChild->evalBatch(local.view(), out);
        for (int i = 0; i < b.n; ++i) out[i] *= mScale;
    }

    void evalIdBatch(const Batch& b, float* out, float* id) const override
    {
        BatchBuffer local;
        toLocal(b, local);
        mChild->evalIdBatch(local.view(), out, id);
        for (int i = 0; i < b.n; ++i) out[i] *= mScale;
    }

    BBoxd bounds() const override
    {
        const BBoxd cb = mChild->bounds();
        if (!isBounded(cb)) return infiniteBounds();
        BBoxd bb;
        for (int k = 0; k < 8; ++k) {
            const Vec3d corner((k & 1) ? cb.max()[0] : cb.min()[0],
                               (k & 2) ? cb.max()[1] : cb.min()[1],
                               (k & 4) ? cb.max()[2] : cb.min()[2]);
            const Vec3d w = mM.transform(corner);
            if (k == 0) bb = BBoxd(w, w); else bb.expand(w);
        }
        return bb;
    }

    double lipschitz() const override { return mChild->lipschitz(); }
    double modulus(double r) const override
    {
        return double(mScale) * mChild->modulus(r * double(mInvNorm));
    }
    bool exact() const override { return mRigidLike && mChild->exact(); }

private:
    void toLocal(const Batch& b, BatchBuffer& local) const
    {
        const float(&m)[4][3] = mInv;
        for (int i = 0; i < b.n; ++i) {
            const float x = b.x[i], y = b.y[i], z = b.z[i];
            local.x[i] = x * m[0][0] + y * m[1][0] + z * m[2][0] + m[3][0];
            local.y[i] = x * m[0][1] + y * m[1][1] + z * m[2][1] + m[3][1];
            local.z[i] = x * m[0][2] + y * m[1][2] + z * m[2][2] + m[3][2];
        }
        local.n = b.n;
        const Vec3f c = b.center;
        for (int a = 0; a < 3; ++a) {
            local.center[a] = c[0] * m[0][a] + c[1] * m[1][a] + c[2] * m[2][a] + m[3][a];
        }
        // Local distances are world distances / σ_min(M) at most; values are scaled back.
        local.radius = b.radius * mInvNorm;
        local.band = b.band / mScale;
        local.reach = b.reach * mInvNorm;
    }

    FieldPtr mChild;
    openvdb::math::Mat4d mM;
    float mInv[4][3];
    float mInvNorm = 1.0f;
    float mScale = 1.0f;
    bool mRigidLike = true;
};

class Warp final : public Field
{
public:
    Warp(FieldPtr child, Displacement::Ptr d) : mChild(std::move(child)), mDelta(std::move(d)) {}

    void evalBatch(const Batch& b, float* out) const override
    {
        BatchBuffer q;
        warped(b, q);
        mChild->evalBatch(q.view(), out);
    }
    void evalIdBatch(const Batch& b, float* out, float* id) const override
    {
        BatchBuffer q;
        warped(b, q);
        mChild->evalIdBatch(q.view(), out, id);
    }
    BBoxd bounds() const override
    {
        BBoxd bb = mChild->bounds();
        if (isBounded(bb)) bb.expand(mDelta->maxMagnitude());
        return bb;
    }
    double lipschitz() const override
    {
        return mChild->lipschitz() * (1.0 + mDelta->lipschitz());
    }
    // |δ(p) - δ(q)| <= min(L_δ·|p - q|, 2·max|δ|): small detail warps add a constant, not a
    // slope.
    double modulus(double r) const override { return mChild->modulus(r + shift(r)); }
    bool exact() const override { return false; }

private:
    void warped(const Batch& b, BatchBuffer& q) const
    {
        mDelta->displace(b, q.x, q.y, q.z);
        for (int i = 0; i < b.n; ++i) {
            q.x[i] += b.x[i];
            q.y[i] += b.y[i];
            q.z[i] += b.z[i];
        }
        q.n = b.n;
        q.center = b.center;
        q.radius = b.radius + float(mDelta->maxMagnitude());
        q.band = b.band;
        // A world distance d maps to at most d + min(L_δ·d, 2·max|δ|) in the warped domain.
        q.reach = std::isfinite(b.reach) ? b.reach + float(shift(double(b.reach))) : b.reach;
    }

    double shift(double r) const
    {
        return std::min(mDelta->lipschitz() * r, 2.0 * mDelta->maxMagnitude());
    }

    FieldPtr mChild;
    Displacement::Ptr mDelta;
};

class NoiseDisplacement final : public Displacement
{
public:
    NoiseDisplacement(double amplitude, noise::Fbm fbm, uint64_t seed)
        : mFbm(fbm), mScale(float(amplitude / fbm.amplitudeSum())), mAmplitude(amplitude)
    {
        for (uint64_t c = 0; c < 3; ++c) mSeed[c] = random::hash(seed, 0x77617270 /*warp*/, c);
    }

    void displace(const Batch& b, float* dx, float* dy, float* dz) const override
    {
        for (int i = 0; i < b.n; ++i) {
            dx[i] = mScale * noise::fbm3(mSeed[0], mFbm, b.x[i], b.y[i], b.z[i]);
            dy[i] = mScale * noise::fbm3(mSeed[1], mFbm, b.x[i], b.y[i], b.z[i]);
            dz[i] = mScale * noise::fbm3(mSeed[2], mFbm, b.x[i], b.y[i], b.z[i]);
        }
    }
    // Each component is bounded by mScale·kValueBound·Σgain^o = 2·amplitude.
    double maxMagnitude() const override
    {
        return std::sqrt(3.0) * noise::kValueBound * mAmplitude;
    }
    // ‖J‖₂ <= ‖J‖_F <= √3 · (per-component gradient bound).
    double lipschitz() const override
    {
        return std::sqrt(3.0) * double(mScale) * mFbm.gradientSum() * noise::kGradientBound3;
    }

private:
    noise::Fbm mFbm;
    uint64_t mSeed[3];
    float mScale;
    double mAmplitude;
};

class Tag final : public Field
{
public:
    Tag(FieldPtr child, float id) : mChild(std::move(child)), mId(id) {}
    void evalBatch(const Batch& b, float* out) const override { mChild->evalBatch(b, out); }
    void evalIdBatch(const Batch& b, float* out, float* id) const override
    {
        mChild->evalBatch(b, out);
        std::fill(id, id + b.n, mId);
    }
    BBoxd bounds() const override { return mChild->bounds(); }
    double lipschitz() const override { return mChild->lipschitz(); }
    double modulus(double r) const override { return mChild->modulus(r); }
    bool exact() const override { return mChild->exact(); }

private:
    FieldPtr mChild;
    float mId;
};

} // namespace

CsgOp csgOpFromString(const std::string& name)
{
    if (name == "union") return CsgOp::Union;
    if (name == "intersection" || name == "intersect") return CsgOp::Intersection;
    if (name == "difference" || name == "subtract") return CsgOp::Difference;
    fail<ValueError>("csg: unknown operation '", name,
                     "' (expected union, intersection or difference)");
}

const char* csgOpName(CsgOp op)
{
    switch (op) {
    case CsgOp::Union: return "union";
    case CsgOp::Intersection: return "intersection";
    case CsgOp::Difference: return "difference";
    }
    return "?";
}

FieldPtr csg(CsgOp op, std::vector<FieldPtr> children, double smoothRadius)
{
    require(!children.empty(), "csg", "number of operands", ">= 1", children.size());
    for (const auto& c : children) {
        if (!c) fail<ValueError>("csg: an operand is null");
    }
    require(std::isfinite(smoothRadius) && smoothRadius >= 0, "csg", "smooth radius", ">= 0",
            smoothRadius);
    if (children.size() == 1) return children.front();
    return std::make_shared<Csg>(op, std::move(children), float(smoothRadius));
}

openvdb::math::Mat4d makeTransform(const Vec3d& translate, const Vec3d& rotateDegrees,
                                   const Vec3d& scale)
{
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    m.preScale(scale);
    m.postRotate(openvdb::math::X_AXIS, rotateDegrees[0] * M_PI / 180.0);
    m.postRotate(openvdb::math::Y_AXIS, rotateDegrees[1] * M_PI / 180.0);
    m.postRotate(openvdb::math::Z_AXIS, rotateDegrees[2] * M_PI / 180.0);
    m.postTranslate(translate);
    return m;
}

FieldPtr transform(FieldPtr child, const openvdb::math::Mat4d& localToWorld)
{
    if (!child) fail<ValueError>("transform: field is null");
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c)
            require(std::isfinite(localToWorld(r, c)), "transform", "matrix entries", "finite",
                    localToWorld(r, c));
    const double det = localToWorld.getMat3().det();
    require(std::abs(det) > 1e-12, "transform", "matrix", "invertible (|det| > 1e-12)", det);
    return std::make_shared<Transform>(std::move(child), localToWorld);
}

FieldPtr warp(FieldPtr child, Displacement::Ptr delta)
{
    if (!child) fail<ValueError>("warp: field is null");
    if (!delta) fail<ValueError>("warp: displacement is null");
    return std::make_shared<Warp>(std::move(child), std::move(delta));
}

Displacement::Ptr noiseDisplacement(double amplitude, double frequency, int octaves,
                                    uint64_t seed, double lacunarity, double gain)
{
    require(std::isfinite(amplitude) && amplitude >= 0, "warp", "amplitude", ">= 0", amplitude);
    noise::Fbm fbm;
    fbm.frequency = frequency;
    fbm.octaves = octaves;
    fbm.lacunarity = lacunarity;
    fbm.gain = gain;
    fbm.validate("warp");
    return std::make_shared<NoiseDisplacement>(amplitude, fbm, seed);
}

FieldPtr tag(FieldPtr child, float id)
{
    if (!child) fail<ValueError>("tag: field is null");
    require(std::isfinite(id) && std::abs(id) < 16777216.0f && id == std::floor(id), "tag", "id",
            "an integer below 2^24", id);
    return std::make_shared<Tag>(std::move(child), id);
}

} // namespace rockvdb
