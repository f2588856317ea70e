// SPDX-License-Identifier: Apache-2.0
#include "Primitives.h"

#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>

#include <algorithm>
#include <cmath>

namespace rockvdb {

namespace {

std::string str(const Vec3d& v)
{
    std::ostringstream os;
    os << v[0] << "," << v[1] << "," << v[2];
    return os.str();
}

bool finite(const Vec3d& v)
{
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

class Sphere final : public Field
{
public:
    Sphere(const Vec3d& c, double r) : mC(c), mR(float(r)), mCenter(c), mRadius(r) {}
    void evalBatch(const Batch& b, float* __restrict out) const override
    {
        const float cx = mC[0], cy = mC[1], cz = mC[2], r = mR;
        const float* __restrict x = b.x;
        const float* __restrict y = b.y;
        const float* __restrict z = b.z;
        for (int i = 0; i < b.n; ++i) {
            const float dx = x[i] - cx, dy = y[i] - cy, dz = z[i] - cz;
            out[i] = std::sqrt(dx * dx + dy * dy + dz * dz) - r;
        }
    }
    BBoxd bounds() const override
    {
        return BBoxd(mCenter - Vec3d(mRadius), mCenter + Vec3d(mRadius));
    }

private:
    Vec3f mC;
    float mR;
    Vec3d mCenter;
    double mRadius;
};

class RoundedBox final : public Field
{
public:
    RoundedBox(const Vec3d& c, const Vec3d& h, double r)
        : mC(c), mInner(h - Vec3d(r)), mR(float(r)), mCenter(c), mHalf(h) {}
    void evalBatch(const Batch& b, float* __restrict out) const override
    {
        const float cx = mC[0], cy = mC[1], cz = mC[2], r = mR;
        const float ix = mInner[0], iy = mInner[1], iz = mInner[2];
        for (int i = 0; i < b.n; ++i) {
            const float qx = std::abs(b.x[i] - cx) - ix;
            const float qy = std::abs(b.y[i] - cy) - iy;
            const float qz = std::abs(b.z[i] - cz) - iz;
            const float ox = std::max(qx, 0.0f), oy = std::max(qy, 0.0f),
                        oz = std::max(qz, 0.0f);
            const float inside = std::min(std::max(qx, std::max(qy, qz)), 0.0f);
            out[i] = std::sqrt(ox * ox + oy * oy + oz * oz) + inside - r;
        }
    }
    BBoxd bounds() const override { return BBoxd(mCenter - mHalf, mCenter + mHalf); }

private:
    Vec3f mC, mInner;
    float mR;
    Vec3d mCenter, mHalf;
};

class Capsule final : public Field
{
public:
    Capsule(const Vec3d& a, const Vec3d& b, double r) : mA(a), mBA(b - a), mR(float(r)),
        mInvLen2(mBA.lengthSqr() > 0 ? 1.0f / mBA.lengthSqr() : 0.0f), mPa(a), mPb(b), mRad(r) {}
    void evalBatch(const Batch& b, float* __restrict out) const override
    {
        const float ax = mA[0], ay = mA[1], az = mA[2];
        const float bx = mBA[0], by = mBA[1], bz = mBA[2], inv = mInvLen2, r = mR;
        for (int i = 0; i < b.n; ++i) {
            const float px = b.x[i] - ax, py = b.y[i] - ay, pz = b.z[i] - az;
            const float h = std::min(std::max((px * bx + py * by + pz * bz) * inv, 0.0f), 1.0f);
            const float dx = px - bx * h, dy = py - by * h, dz = pz - bz * h;
            out[i] = std::sqrt(dx * dx + dy * dy + dz * dz) - r;
        }
    }
    BBoxd bounds() const override
    {
        BBoxd bb(minComponent(mPa, mPb), maxComponent(mPa, mPb));
        bb.expand(mRad);
        return bb;
    }

private:
    Vec3f mA, mBA;
    float mR, mInvLen2;
    Vec3d mPa, mPb;
    double mRad;
};

class HalfSpace final : public Field
{
public:
    HalfSpace(const Vec3d& n, double d) : mN(n), mD(float(d)) {}
    void evalBatch(const Batch& b, float* __restrict out) const override
    {
        const float nx = mN[0], ny = mN[1], nz = mN[2], d = mD;
        for (int i = 0; i < b.n; ++i) out[i] = b.x[i] * nx + b.y[i] * ny + b.z[i] * nz - d;
    }
    BBoxd bounds() const override { return infiniteBounds(); }

private:
    Vec3f mN;
    float mD;
};

class Polytope final : public Field
{
public:
    Polytope(std::vector<Plane> planes, double r) : mPlanes(std::move(planes)), mR(float(r))
    {
        const auto verts = polytopeVertices(mPlanes);
        if (verts.empty()) {
            mBounds = infiniteBounds();
        } else {
            mBounds = BBoxd(verts.front(), verts.front());
            for (const auto& v : verts) mBounds.expand(v);
        }
    }
    void evalBatch(const Batch& b, float* __restrict out) const override
    {
        const int n = b.n;
        std::fill(out, out + n, -std::numeric_limits<float>::max());
        bool first = true;
        for (const Plane& p : mPlanes) {
            const float nx = float(p.normal[0]), ny = float(p.normal[1]),
                        nz = float(p.normal[2]), d = float(p.offset);
            if (mR > 0 && !first) {
                for (int i = 0; i < n; ++i) {
                    const float h = b.x[i] * nx + b.y[i] * ny + b.z[i] * nz - d;
                    out[i] = smoothIntersection(out[i], h, mR);
                }
            } else {
                for (int i = 0; i < n; ++i) {
                    out[i] = std::max(out[i], b.x[i] * nx + b.y[i] * ny + b.z[i] * nz - d);
                }
            }
            first = false;
        }
    }
    BBoxd bounds() const override { return mBounds; }
    bool exact() const override { return false; }

private:
    std::vector<Plane> mPlanes;
    float mR;
    BBoxd mBounds;
};

} // namespace

FieldPtr sphere(const Vec3d& center, double radius)
{
    require(finite(center), "sphere", "center", "finite", str(center));
    require(std::isfinite(radius) && radius > 0, "sphere", "radius", "> 0", radius);
    return std::make_shared<Sphere>(center, radius);
}

FieldPtr box(const Vec3d& center, const Vec3d& halfSize, double rounding)
{
    require(finite(center), "box", "center", "finite", str(center));
    require(finite(halfSize) && halfSize[0] > 0 && halfSize[1] > 0 && halfSize[2] > 0, "box",
            "size", "> 0 on every axis", str(halfSize * 2.0));
    require(std::isfinite(rounding) && rounding >= 0 && rounding <= std::min({halfSize[0], halfSize[1], halfSize[2]}),
            "box", "rounding", "in [0, half the smallest size]", rounding);
    return std::make_shared<RoundedBox>(center, halfSize, rounding);
}

FieldPtr capsule(const Vec3d& a, const Vec3d& b, double radius)
{
    require(finite(a), "capsule", "end point a", "finite", str(a));
    require(finite(b), "capsule", "end point b", "finite", str(b));
    require(std::isfinite(radius) && radius > 0, "capsule", "radius", "> 0", radius);
    return std::make_shared<Capsule>(a, b, radius);
}

FieldPtr halfSpace(const Vec3d& point, const Vec3d& normal)
{
    require(finite(point), "plane", "point", "finite", str(point));
    require(finite(normal) && normal.length() > 1e-12, "plane", "normal", "non-zero",
            str(normal));
    const Vec3d n = normal.unit();
    return std::make_shared<HalfSpace>(n, n.dot(point));
}

std::vector<Vec3d> polytopeVertices(const std::vector<Plane>& planes)
{
    std::vector<Vec3d> verts;
    const size_t n = planes.size();
    if (n < 4) return verts;
    double scale = 1.0;
    for (const Plane& p : planes) scale = std::max(scale, std::abs(p.offset));
    const double eps = 1e-9 * scale;
    for (size_t a = 0; a < n; ++a) {
        for (size_t b = a + 1; b < n; ++b) {
            const Vec3d nab = planes[a].normal.cross(planes[b].normal);
            for (size_t c = b + 1; c < n; ++c) {
                const double det = nab.dot(planes[c].normal);
                if (std::abs(det) < 1e-12) continue;
                // Cramer: p = (d_a (n_b × n_c) + d_b (n_c × n_a) + d_c (n_a × n_b)) / det
                const Vec3d p = (planes[a].offset * planes[b].normal.cross(planes[c].normal) +
                                 planes[b].offset * planes[c].normal.cross(planes[a].normal) +
                                 planes[c].offset * nab) / det;
                bool inside = true;
                for (const Plane& q : planes) {
                    if (q.normal.dot(p) - q.offset > eps) { inside = false; break; }
                }
                if (inside) verts.push_back(p);
            }
        }
    }
    if (verts.empty()) return verts;
    // Bounded iff the recession cone {v : n_k·v <= 0 for all k} is {0}. It holds a line when
    // the normals have rank < 3; otherwise it is pointed and its extreme rays are ±(n_a × n_b).
    bool rank3 = false;
    std::vector<Vec3d> rays;
    for (size_t a = 0; a < n; ++a)
        for (size_t b = a + 1; b < n; ++b) {
            const Vec3d r = planes[a].normal.cross(planes[b].normal);
            if (r.length() < 1e-12) continue;
            rays.push_back(r.unit());
            rays.push_back(-r.unit());
            for (size_t c = 0; c < n && !rank3; ++c) {
                rank3 = std::abs(r.dot(planes[c].normal)) > 1e-9;
            }
        }
    if (!rank3) return {};
    for (const Vec3d& r : rays) {
        bool escapes = true;
        for (const Plane& q : planes) {
            if (q.normal.dot(r) > 1e-9 * q.normal.length()) { escapes = false; break; }
        }
        if (escapes) return {};
    }
    return verts;
}

FieldPtr convexPolytope(const std::vector<Plane>& planes, double smoothRadius)
{
    require(!planes.empty(), "polytope", "number of planes", ">= 1", planes.size());
    // The vertex enumeration (its bounds) is cubic in the planes and every voxel evaluates
    // all of them: thousands of planes would run for minutes, so they are refused up front.
    static_assert(kMaxPolytopePlanes == 512, "the message below names the limit");
    require(planes.size() <= kMaxPolytopePlanes, "polytope", "number of planes",
            "<= 512 (the work is cubic in the planes)", planes.size());
    require(std::isfinite(smoothRadius) && smoothRadius >= 0, "polytope", "smooth radius",
            ">= 0", smoothRadius);
    std::vector<Plane> unit;
    unit.reserve(planes.size());
    for (const Plane& p : planes) {
        const double len = p.normal.length();
        require(finite(p.normal) && len > 1e-12 && std::isfinite(p.offset), "polytope",
                "plane normal", "finite and non-zero", str(p.normal));
        unit.push_back({p.normal / len, p.offset / len});
    }
    return std::make_shared<Polytope>(std::move(unit), smoothRadius);
}

} // namespace rockvdb
