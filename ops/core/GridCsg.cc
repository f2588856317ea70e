// SPDX-License-Identifier: Apache-2.0
#include "GridCsg.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/ExtendBand.h>
#include <rockvdb/core/VdbIO.h>

#include <openvdb/tools/Composite.h>
#include <openvdb/tools/GridTransformer.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tree/LeafManager.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace rockvdb {

using openvdb::FloatGrid;

namespace {

// What resampling @a g onto @a ref's transform allocates: tools::resampleToMatch rebuilds a
// level set (mesh at g's resolution, then a narrow band at ref's), so the new band holds the
// surface area in ref's voxels: g's band voxels x (dx_g / dx_ref)² x (band ratio), about 16 B
// each with the rebuild's index grid. A coarse input resampled onto a much finer first input
// grows with the square of the ratio.
double resampleBytes(const FloatGrid& g, const FloatGrid& ref)
{
    if (g.transform() == ref.transform()) return double(g.memUsage());
    const double dxg = g.voxelSize()[0], dxr = ref.voxelSize()[0];
    const double hwg = std::max(1.0, double(g.background()) / dxg);
    const double hwr = std::max(1.0, double(ref.background()) / dxr);
    const double area = double(g.activeVoxelCount()) / (2.0 * hwg) * dxg * dxg;
    return area / (dxr * dxr) * 2.0 * hwr * 16.0;
}

FloatGrid::Ptr onTransformOf(const FloatGrid& g, const FloatGrid& ref)
{
    if (g.transform() == ref.transform()) return g.deepCopy();
    auto out = FloatGrid::create(ref.background());
    out->setTransform(ref.transform().copy());
    out->setGridClass(openvdb::GRID_LEVEL_SET);
    openvdb::tools::resampleToMatch<openvdb::tools::BoxSampler>(g, *out);
    return out;
}

} // namespace

FloatGrid::Ptr csgGrids(CsgOp op, const std::vector<FloatGrid::ConstPtr>& grids, double r,
                        double maxMemoryBytes)
{
    initialize();
    require(!grids.empty(), "csg", "number of inputs", ">= 1", grids.size());
    require(std::isfinite(r) && r >= 0, "csg", "smooth radius", ">= 0", r);
    for (size_t i = 0; i < grids.size(); ++i) {
        if (!grids[i]) fail<ValueError>("csg: input ", i, " is null");
        requireLevelSet(*grids[i], "csg input " + std::to_string(i));
    }
    const FloatGrid& ref = *grids[0];
    const double limit = memoryLimitBytes(maxMemoryBytes);
    double copies = 0;
    for (size_t i = 0; i < grids.size(); ++i) {
        const double bytes = resampleBytes(*grids[i], ref);
        copies += bytes;
        if (copies > limit) {
            fail<ValueError>("csg: input ", i + 1, " (voxel size ", grids[i]->voxelSize()[0],
                             " m) on the first input's voxel size ", ref.voxelSize()[0],
                             " m needs about ", formatBytes(copies), ", over the ", formatBytes(limit),
                             " allowed; give the coarsest input first, or raise --max-memory");
        }
    }
    std::vector<FloatGrid::Ptr> in;
    for (const auto& g : grids) in.push_back(onTransformOf(*g, ref));

    FloatGrid::Ptr result = in[0];
    if (r == 0) {
        for (size_t i = 1; i < in.size(); ++i) {
            switch (op) {
            case CsgOp::Union: openvdb::tools::csgUnion(*result, *in[i]); break;
            case CsgOp::Intersection: openvdb::tools::csgIntersection(*result, *in[i]); break;
            case CsgOp::Difference: openvdb::tools::csgDifference(*result, *in[i]); break;
            }
        }
    } else {
        const double dx = ref.voxelSize()[0];
        const float bg = ref.background();
        const float rf = float(r);
        // Values the operator needs: |result| < bg requires operands up to bg + R/6 + R.
        const int dilation = int(std::ceil((7.0 / 6.0) * r / dx)) + 1;
        // Upper bound of what widening allocates: every voxel of each input's active
        // bounding box grown by the dilation (the widened band can fill it), ~5 B per voxel
        // in leaves, operands and result alive at once. Linear-in-R estimates undercount: a
        // large offset of a small shape grows with the cube of the dilation.
        double bytes = 0;
        for (const auto& g : in) {
            const openvdb::Coord ext = g->evalActiveVoxelDim();
            double voxels = 1;
            for (int a = 0; a < 3; ++a) voxels *= double(ext[a]) + 2.0 * dilation;
            bytes += voxels * 5.0;
        }
        bytes *= 1.5;
        if (bytes > limit) {
            fail<ValueError>("csg: refusing smooth radius ", r, " m at voxel size ", dx,
                             " m: widening the bands needs about ", formatBytes(bytes),
                             ", over the ", formatBytes(limit),
                             " allowed; use a smaller --smooth, or raise --max-memory");
        }
        FloatGrid::Ptr acc = extendBand(*result, dilation);
        for (size_t i = 1; i < in.size(); ++i) {
            FloatGrid::Ptr b = extendBand(*in[i], dilation);
            auto out = FloatGrid::create(bg);
            out->setTransform(ref.transform().copy());
            out->tree().topologyUnion(acc->tree());
            out->tree().topologyUnion(b->tree());
            openvdb::tree::LeafManager<openvdb::FloatTree> leaves(out->tree());
            const FloatGrid& A = *acc;
            const FloatGrid& B = *b;
            leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
                openvdb::tree::ValueAccessor<const openvdb::FloatTree, false> aa(A.tree()), bb(B.tree());
                for (auto it = leaf.beginValueOn(); it; ++it) {
                    const auto ijk = it.getCoord();
                    const float va = aa.getValue(ijk), vb = bb.getValue(ijk);
                    float v = 0;
                    switch (op) {
                    case CsgOp::Union: v = smoothUnion(va, vb, rf); break;
                    case CsgOp::Intersection: v = smoothIntersection(va, vb, rf); break;
                    case CsgOp::Difference: v = smoothDifference(va, vb, rf); break;
                    }
                    it.setValue(v);
                }
            });
            openvdb::tools::signedFloodFill(out->tree());
            acc = out;
        }
        // Clip back to the first input's band.
        openvdb::tree::LeafManager<openvdb::FloatTree> leaves(acc->tree());
        leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
            for (auto it = leaf.beginValueOn(); it; ++it) {
                const float v = *it;
                if (std::abs(v) >= bg) {
                    it.setValue(v < 0 ? -bg : bg);
                    it.setValueOff();
                }
            }
        });
        openvdb::tools::pruneLevelSet(acc->tree());
        openvdb::tools::signedFloodFill(acc->tree());
        result = acc;
    }
    result->setGridClass(openvdb::GRID_LEVEL_SET);
    result->setName(ref.getName().empty() ? "surface" : ref.getName());
    return result;
}

FloatGrid::Ptr csgAttribute(CsgOp op, const std::vector<FloatGrid::ConstPtr>& surfaces,
                            const std::vector<FloatGrid::ConstPtr>& ids, const FloatGrid& result,
                            const std::string& name)
{
    require(!surfaces.empty() && ids.size() == surfaces.size(), "csg", "id grids per input",
            "one (or null) per input", ids.size());
    auto out = FloatGrid::create(-1.0f);
    out->setTransform(result.transform().copy());
    out->setGridClass(openvdb::GRID_UNKNOWN);
    out->setName(name);
    out->tree().topologyUnion(result.tree());
    const size_t n = surfaces.size();
    std::vector<bool> sameXf(n);
    for (size_t i = 0; i < n; ++i) {
        if (!surfaces[i]) fail<ValueError>("csg: input ", i, " is null");
        sameXf[i] = surfaces[i]->transform() == result.transform() &&
                    (!ids[i] || ids[i]->transform() == result.transform());
    }
    // Accessors per range of leaves, unregistered: a registered accessor per leaf cost more
    // than the leaf's look-ups (its tree's registry is a concurrent hash map).
    using Accessor = openvdb::tree::ValueAccessor<const openvdb::FloatTree, false>;
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(out->tree());
    tbb::parallel_for(leaves.leafRange(), [&](const auto& range) {
        std::vector<Accessor> phi, id;
        for (size_t i = 0; i < n; ++i) {
            phi.emplace_back(surfaces[i]->tree());
            id.emplace_back((ids[i] ? ids[i] : surfaces[i])->tree());
        }
        for (auto leafIt = range.begin(); leafIt; ++leafIt) {
            for (auto it = leafIt->beginValueOn(); it; ++it) {
                const openvdb::Coord ijk = it.getCoord();
                const openvdb::Vec3d p = result.transform().indexToWorld(ijk);
                auto value = [&](size_t i) -> float {
                    if (sameXf[i]) return phi[i].getValue(ijk);
                    const openvdb::Vec3d q = surfaces[i]->transform().worldToIndex(p);
                    return openvdb::tools::BoxSampler::sample(phi[i], q);
                };
                size_t win = 0;
                if (op != CsgOp::Difference) {
                    float best = value(0);
                    for (size_t i = 1; i < n; ++i) {
                        const float v = value(i);
                        if (op == CsgOp::Union ? v < best : v > best) {
                            best = v;
                            win = i;
                        }
                    }
                }
                float v = -1.0f;
                if (ids[win]) {
                    v = sameXf[win] ? id[win].getValue(ijk)
                                    : id[win].getValue(ids[win]->transform().worldToIndexCellCentered(p));
                }
                it.setValue(v);
            }
        }
    });
    return out;
}

CsgInput readCsgInput(const std::string& path, const std::string& gridName, bool withIds)
{
    const openvdb::GridPtrVecPtr all = readGrids(path);
    CsgInput in;
    in.surface = findLevelSet(*all, gridName, path == "-" ? "<stdin>" : path);
    if (!withIds) return in;
    for (const auto& gb : *all) {
        auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(gb);
        if (f && f != in.surface && f->getGridClass() != openvdb::GRID_LEVEL_SET) in.ids.push_back(f);
    }
    return in;
}

openvdb::GridPtrVec csgWithIds(CsgOp op, const std::vector<CsgInput>& inputs, double smoothRadius,
                               double maxMemoryBytes)
{
    std::vector<openvdb::FloatGrid::ConstPtr> surfaces;
    std::vector<std::string> names;
    for (const auto& in : inputs) {
        surfaces.push_back(in.surface);
        for (const auto& g : in.ids) {
            if (std::find(names.begin(), names.end(), g->getName()) == names.end()) {
                names.push_back(g->getName());
            }
        }
    }
    auto result = csgGrids(op, surfaces, smoothRadius, maxMemoryBytes);
    openvdb::GridPtrVec out{result};
    for (const auto& name : names) {
        std::vector<openvdb::FloatGrid::ConstPtr> per;
        for (const auto& in : inputs) {
            openvdb::FloatGrid::ConstPtr found;
            for (const auto& g : in.ids) {
                if (g->getName() == name && !found) found = g;
            }
            per.push_back(found);
        }
        out.push_back(csgAttribute(op, surfaces, per, *result, name));
    }
    return out;
}

} // namespace rockvdb
