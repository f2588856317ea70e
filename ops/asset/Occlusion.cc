// SPDX-License-Identifier: Apache-2.0
#include "Occlusion.h"

#include <rockvdb/core/Error.h>

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace rockvdb {
namespace asset {

namespace {

constexpr int kCones = 24;
constexpr double kHalfAngle = 20.0 * M_PI / 180.0;

// Cone axes in the local frame (z = the normal): evenly spread in solid angle over the cap of
// elevation ≥ θ (z = sin(elevation) uniform in [sin θ, 1], azimuths by the golden angle).
const std::array<openvdb::Vec3d, kCones>& coneAxes()
{
    static const std::array<openvdb::Vec3d, kCones> axes = [] {
        std::array<openvdb::Vec3d, kCones> a;
        const double z0 = std::sin(kHalfAngle), golden = M_PI * (3.0 - std::sqrt(5.0));
        for (int i = 0; i < kCones; ++i) {
            const double z = z0 + (1.0 - z0) * (i + 0.5) / kCones;
            const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
            a[size_t(i)] = openvdb::Vec3d(r * std::cos(i * golden), r * std::sin(i * golden), z);
        }
        return a;
    }();
    return axes;
}

template<typename Accessor>
double traceWith(const Occlusion& occ, Accessor& acc, const openvdb::Vec3d& p, const openvdb::Vec3d& nIn)
{
    const openvdb::math::Transform& xf = occ.field->transform();
    auto phi = [&](const openvdb::Vec3d& x) {
        return double(openvdb::tools::BoxSampler::sample(acc, xf.worldToIndex(x)));
    };
    const double nl = nIn.length();
    if (!(nl > 1e-12)) return 1.0;
    const openvdb::Vec3d n = nIn / nl;
    // a frame (t, b, n)
    const openvdb::Vec3d any = std::abs(n.x()) < 0.9 ? openvdb::Vec3d(1, 0, 0) : openvdb::Vec3d(0, 1, 0);
    const openvdb::Vec3d t = (any - n * n.dot(any)).unit(), b = n.cross(t);
    const double hc = occ.voxel, D = occ.distance, sinT = std::sin(kHalfAngle);
    const openvdb::Vec3d o = p + hc * n;
    double weighted = 0, weights = 0;
    for (const openvdb::Vec3d& a : coneAxes()) {
        const openvdb::Vec3d d = a.x() * t + a.y() * b + a.z() * n;
        double vis = 1.0, s = 0;
        for (double s_t = hc; s_t < D && vis > 0; s_t += std::max(s, 0.5 * hc)) {
            s = phi(o + s_t * d);
            vis = std::min(vis, std::max(0.0, s) / (s_t * sinT));
        }
        weighted += a.z() * std::min(1.0, vis);
        weights += a.z();
    }
    return weighted / weights;
}

} // namespace

double traceOcclusion(const Occlusion& occ, const openvdb::Vec3d& p, const openvdb::Vec3d& n)
{
    auto acc = occ.field->getConstAccessor();
    return traceWith(occ, acc, p, n);
}

Occlusion occlusion(const TriMesh& mesh, double fineVoxel, double distance, Task& task)
{
    require(std::isfinite(distance) && distance > 0, "asset", "ao-distance", "> 0", distance);
    if (mesh.triangles() == 0) fail<ValueError>("asset: no triangles to compute occlusion from");
    Occlusion occ;
    occ.distance = distance;
    occ.voxel = std::max(fineVoxel, distance / 12.0);
    const auto xf = openvdb::math::Transform::createLinearTransform(occ.voxel);
    std::vector<openvdb::Vec3s> points(mesh.points.begin(), mesh.points.end());
    std::vector<openvdb::Vec3I> tris(mesh.triangles());
    for (size_t i = 0; i < tris.size(); ++i) {
        tris[i] = openvdb::Vec3I(mesh.indices[3 * i], mesh.indices[3 * i + 1], mesh.indices[3 * i + 2]);
    }
    const float exBand = float(distance / occ.voxel + 2.0);
    occ.field = openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(
        *task.interrupter(), *xf, points, tris, std::vector<openvdb::Vec4I>(), exBand, 3.0f);
    task.check();

    // The occlusion grid: voxels within 2 hc of the surface, each from its nearest surface
    // point p = x - φ(x)∇φ(x) and the field's normal ∇φ there.
    auto value = openvdb::FloatGrid::create(1.0f);
    value->setTransform(xf->copy());
    value->setName("occlusion");
    {
        const float reach = float(2.0 * occ.voxel);
        auto vacc = value->getAccessor();
        for (auto it = occ.field->cbeginValueOn(); it; ++it) {
            if (std::abs(*it) <= reach) vacc.setValueOn(it.getCoord(), 1.0f);
        }
    }
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(value->tree());
    parallelFor(task, leaves.leafCount(), 4, [&](size_t li) {
        auto& leaf = leaves.leaf(li);
        openvdb::tree::ValueAccessor<const openvdb::FloatTree, false> acc(occ.field->tree());
        const openvdb::math::Transform& fx = occ.field->transform();
        auto phi = [&](const openvdb::Vec3d& x) {
            return double(openvdb::tools::BoxSampler::sample(acc, fx.worldToIndex(x)));
        };
        const double h = occ.voxel;
        for (auto it = leaf.beginValueOn(); it; ++it) {
            const openvdb::Vec3d x = fx.indexToWorld(it.getCoord());
            openvdb::Vec3d g(phi(x + openvdb::Vec3d(h, 0, 0)) - phi(x - openvdb::Vec3d(h, 0, 0)),
                             phi(x + openvdb::Vec3d(0, h, 0)) - phi(x - openvdb::Vec3d(0, h, 0)),
                             phi(x + openvdb::Vec3d(0, 0, h)) - phi(x - openvdb::Vec3d(0, 0, h)));
            const double gl = g.length();
            if (!(gl > 1e-12)) continue; // no direction: left open (1)
            g /= gl;
            const openvdb::Vec3d p = x - phi(x) * g;
            it.setValue(float(traceWith(occ, acc, p, g)));
        }
    });
    occ.value = value;
    return occ;
}

} // namespace asset
} // namespace rockvdb
