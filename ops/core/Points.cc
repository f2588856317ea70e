// SPDX-License-Identifier: Apache-2.0
// Instances as a VDB points grid (Points.h).
#include <rockvdb/core/Points.h>

#include <rockvdb/core/Error.h>

#include <openvdb/points/PointAttribute.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointDataGrid.h>
#include <openvdb/tools/PointIndexGrid.h>

namespace rockvdb {

namespace {

template<typename T>
void add(openvdb::points::PointDataGrid& pts, const openvdb::tools::PointIndexGrid& index,
         const std::string& name, const std::vector<T>& values)
{
    using namespace openvdb::points;
    appendAttribute<T>(pts.tree(), name);
    populateAttribute<PointDataTree, openvdb::tools::PointIndexTree, PointAttributeVector<T>>(
        pts.tree(), index.tree(), name, PointAttributeVector<T>(values));
}

} // namespace

openvdb::GridBase::Ptr instancePointsGrid(const InstancePoints& p, double voxelSize,
                                          const std::string& name)
{
    const size_t n = p.positions.size();
    bool same = p.orient.size() == n && p.pscale.size() == n && p.variant.size() == n;
    for (const auto& a : p.ints) same = same && a.second.size() == n;
    same = same && (p.scale.empty() || p.scale.size() == n) && (p.pivot.empty() || p.pivot.size() == n);
    if (!same) fail<ValueError>("points: attributes of different lengths for ", n, " positions");
    std::vector<int32_t> id(n);
    for (size_t i = 0; i < n; ++i) id[i] = int32_t(i);
    auto xf = openvdb::math::Transform::createLinearTransform(voxelSize);
    openvdb::points::PointAttributeVector<openvdb::Vec3d> wrapper(p.positions);
    auto index = openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(wrapper, *xf);
    auto pts = openvdb::points::createPointDataGrid<openvdb::points::NullCodec,
                                                    openvdb::points::PointDataGrid>(*index, wrapper, *xf);
    add(*pts, *index, "orient", p.orient);
    add(*pts, *index, "pscale", p.pscale);
    add(*pts, *index, "variant", p.variant);
    add(*pts, *index, "id", id);
    if (!p.scale.empty()) add(*pts, *index, "scale", p.scale);
    if (!p.pivot.empty()) add(*pts, *index, "pivot", p.pivot);
    for (const auto& [attr, values] : p.ints) add(*pts, *index, attr, values);
    pts->setName(name);
    return pts;
}

} // namespace rockvdb
