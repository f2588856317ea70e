// SPDX-License-Identifier: Apache-2.0
#include "GridField.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/ExtendBand.h>
#include <rockvdb/core/VdbIO.h>

#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tree/LeafManager.h>
#include <openvdb/tools/GridOperators.h>
#include <openvdb/tools/Interpolation.h>

#include <tbb/task_arena.h>

#include <cmath>
#include <memory>
#include <mutex>

namespace rockvdb {

namespace {

// Trilinear interpolation at index-space @a xyz. When the 2×2×2 corners lie in one leaf
// (7/8 of the time per axis) they are read straight from its buffer: one tree lookup
// instead of eight.
template <typename AccT>
inline auto trilinear(AccT& acc, const Vec3d& xyz)
{
    using ValueT = typename AccT::ValueType;
    // floor without libm calls (SSE2 has no floor instruction).
    auto ifloor = [](double v) {
        const int i = int(v);
        return i - (double(i) > v ? 1 : 0);
    };
    const openvdb::Coord ijk(ifloor(xyz[0]), ifloor(xyz[1]), ifloor(xyz[2]));
    const float w = float(xyz[2] - ijk.z());
    const float fu = float(xyz[0] - ijk.x()), fv = float(xyz[1] - ijk.y());
    // At a voxel centre (bakes on the grid's own voxels): the stored value.
    if (fu == 0.0f && fv == 0.0f && w == 0.0f) return ValueT(acc.getValue(ijk));
    ValueT c[8];
    const int lx = ijk.x() & 7, ly = ijk.y() & 7, lz = ijk.z() & 7;
    const auto* leaf = (lx < 7 && ly < 7 && lz < 7) ? acc.probeConstLeaf(ijk) : nullptr;
    if (leaf) {
        const ValueT* d = leaf->buffer().data() + ((lx << 6) | (ly << 3) | lz);
        c[0] = d[0];  c[1] = d[1];  c[2] = d[8];  c[3] = d[9];
        c[4] = d[64]; c[5] = d[65]; c[6] = d[72]; c[7] = d[73];
    } else {
        for (int n = 0; n < 8; ++n) {
            c[n] = acc.getValue(ijk.offsetBy((n >> 2) & 1, (n >> 1) & 1, n & 1));
        }
    }
    // c[n]: n = 4·dx + 2·dy + dz.
    const ValueT z00 = c[0] + (c[1] - c[0]) * w, z01 = c[2] + (c[3] - c[2]) * w;
    const ValueT z10 = c[4] + (c[5] - c[4]) * w, z11 = c[6] + (c[7] - c[6]) * w;
    const ValueT y0 = z00 + (z01 - z00) * fv, y1 = z10 + (z11 - z10) * fv;
    return ValueT(y0 + (y1 - y0) * fu);
}

class LevelSetField final : public Field
{
public:
    explicit LevelSetField(openvdb::FloatGrid::ConstPtr g) : mGrid(std::move(g))
    {
        const openvdb::CoordBBox bb = mGrid->evalActiveVoxelBoundingBox();
        mBounds = BBoxd(mGrid->indexToWorld(bb.min()), mGrid->indexToWorld(bb.max()));
        const openvdb::math::Transform& xf = mGrid->transform();
        // Axis-aligned uniform voxels (every grid rockvdb writes): index = (p - origin) / dx.
        mFast = xf.isLinear() && xf.hasUniformScale() &&
                (xf.mapType() == openvdb::math::UniformScaleMap::mapType() ||
                 xf.mapType() == openvdb::math::UniformScaleTranslateMap::mapType());
        mOrigin = xf.indexToWorld(Vec3d(0.0));
        mInvDx = 1.0 / mGrid->voxelSize()[0];
        // The maps' own 1/(2dx) (ScaleMap::getInvTwiceScale), as math::Gradient uses it.
        if (auto m = xf.constMap<openvdb::math::UniformScaleMap>()) {
            mInv2dx = float(m->getInvTwiceScale()[0]);
        } else if (auto t = xf.constMap<openvdb::math::UniformScaleTranslateMap>()) {
            mInv2dx = float(t->getInvTwiceScale()[0]);
        }
    }

    void evalBatch(const Batch& b, float* out) const override
    {
        auto acc = mGrid->getConstAccessor();
        for (int i = 0; i < b.n; ++i) {
            out[i] = trilinear(acc, index(b.x[i], b.y[i], b.z[i]));
        }
    }

    // The grid's central-difference gradient (tools::gradient's): at the grid's own voxels
    // taken on the fly from six neighbours (the bakes that read the gradient sample voxel
    // centres: no 12-byte-per-voxel gradient grid, and the values just read are in cache);
    // elsewhere trilinear samples of the gradient grid, built on first use (8 lookups
    // instead of 6 trilinear samples).
    void gradientBatch(const Batch& b, float, float* gx, float* gy, float* gz) const override
    {
        auto acc = mGrid->getConstAccessor();
        LeafBlock leaves(acc);
        std::unique_ptr<openvdb::Vec3SGrid::ConstAccessor> gacc;
        for (int i = 0; i < b.n; ++i) {
            const Vec3d q = index(b.x[i], b.y[i], b.z[i]);
            // Within 1e-3 voxel of a voxel centre: that voxel's gradient. Float positions
            // (i·dx) are up to |i|·8e-8 voxel off (1e-5 at i = 163 of the demo, beyond
            // index()'s snap), and the gradient changes by ~1e-3·dx·curvature there.
            const Vec3d r = nearestInteger(q);
            if (mFast && std::abs(q[0] - r[0]) < 1e-3 && std::abs(q[1] - r[1]) < 1e-3 &&
                std::abs(q[2] - r[2]) < 1e-3) {
                const openvdb::Coord ijk{int(r[0]), int(r[1]), int(r[2])};
                const openvdb::Vec3f g = centralGradient(leaves, ijk);
                gx[i] = g[0];
                gy[i] = g[1];
                gz[i] = g[2];
                continue;
            }
            if (!gacc) {
                prepareGradient();
                gacc = std::make_unique<openvdb::Vec3SGrid::ConstAccessor>(mGradient->getConstAccessor());
            }
            const openvdb::Vec3f g = trilinear(*gacc, q);
            gx[i] = g[0];
            gy[i] = g[1];
            gz[i] = g[2];
        }
    }

    void prepareGradient() const override
    {
        // Isolated: while this thread runs the (parallel) gradient operator it must not pick
        // up another bake task that would wait on this same once-flag (a deadlock).
        std::call_once(mGradientOnce, [this] {
            tbb::this_task_arena::isolate([this] { mGradient = openvdb::tools::gradient(*mGrid); });
        });
    }

    BBoxd bounds() const override { return mBounds; }

private:
    // The leaves around one leaf (a batch's points lie in a leaf and its one-voxel apron),
    // looked up once per batch: a voxel and its six neighbours cost no tree lookups.
    class LeafBlock
    {
    public:
        explicit LeafBlock(const openvdb::FloatGrid::ConstAccessor& acc) : mAcc(acc) {}
        // Value and active state at ijk.
        float get(const openvdb::Coord& ijk, bool* on = nullptr)
        {
            if (const LeafT* l = leaf(ijk)) {
                const openvdb::Index p = LeafT::coordToOffset(ijk);
                if (on) *on = l->isValueOn(p);
                return l->getValue(p);
            }
            if (on) *on = mAcc.isValueOn(ijk);
            return mAcc.getValue(ijk);
        }

        // The leaf holding ijk, or null.
        const openvdb::FloatTree::LeafNodeType* leaf(const openvdb::Coord& ijk)
        {
            const openvdb::Coord o = ijk & ~7;
            if (!mHasBase) {
                mBase = o;
                mHasBase = true;
            }
            const int i = (o.x() - mBase.x()) / 8 + 1, j = (o.y() - mBase.y()) / 8 + 1,
                      k = (o.z() - mBase.z()) / 8 + 1;
            const LeafT* leaf;
            if (i >= 0 && i < 3 && j >= 0 && j < 3 && k >= 0 && k < 3) {
                const int n = (i * 3 + j) * 3 + k;
                if (!mLooked[n]) {
                    mLeaf[n] = mAcc.probeConstLeaf(ijk);
                    mLooked[n] = true;
                }
                leaf = mLeaf[n];
            } else {
                leaf = mAcc.probeConstLeaf(ijk);
            }
            return leaf;
        }

    private:
        using LeafT = openvdb::FloatTree::LeafNodeType;
        const openvdb::FloatGrid::ConstAccessor& mAcc;
        openvdb::Coord mBase;
        bool mHasBase = false;
        bool mLooked[27] = {};
        const LeafT* mLeaf[27] = {};
    };

    // tools::gradient's value at voxel ijk, bit for bit: math::Gradient<UniformScale(Translate)
    // Map, CD_2ND>, (v(+1) − v(−1)) · float(1 / 2dx) per axis, on the active voxels; zero (the
    // gradient grid's background) elsewhere.
    openvdb::Vec3f centralGradient(LeafBlock& leaves, const openvdb::Coord& ijk) const
    {
        const int x = ijk.x() & 7, y = ijk.y() & 7, z = ijk.z() & 7;
        if (x > 0 && x < 7 && y > 0 && y < 7 && z > 0 && z < 7) {
            // All six neighbours in the voxel's own leaf.
            if (const auto* leaf = leaves.leaf(ijk)) {
                const openvdb::Index p = openvdb::Index((x << 6) | (y << 3) | z);
                if (!leaf->isValueOn(p)) return openvdb::Vec3f(0.0f);
                const float* d = leaf->buffer().data() + p;
                return openvdb::Vec3f(d[64] - d[-64], d[8] - d[-8], d[1] - d[-1]) * mInv2dx;
            }
        }
        bool on = false;
        leaves.get(ijk, &on);
        if (!on) return openvdb::Vec3f(0.0f);
        const float x1 = leaves.get(ijk.offsetBy(1, 0, 0)), x0 = leaves.get(ijk.offsetBy(-1, 0, 0));
        const float y1 = leaves.get(ijk.offsetBy(0, 1, 0)), y0 = leaves.get(ijk.offsetBy(0, -1, 0));
        const float z1 = leaves.get(ijk.offsetBy(0, 0, 1)), z0 = leaves.get(ijk.offsetBy(0, 0, -1));
        return openvdb::Vec3f(x1 - x0, y1 - y0, z1 - z0) * mInv2dx;
    }

    // Index-space position; within 1e-5 of a voxel centre it snaps to it, so samples at the
    // grid's own voxels return their stored values exactly (float positions are i·dx ± ulp).
    Vec3d index(float x, float y, float z) const
    {
        const Vec3d p(x, y, z);
        Vec3d q = mFast ? (p - mOrigin) * mInvDx : mGrid->transform().worldToIndex(p);
        const Vec3d r = nearestInteger(q);
        for (int a = 0; a < 3; ++a) {
            if (std::abs(q[a] - r[a]) < 1e-5) q[a] = r[a];
        }
        return q;
    }

    // Nearest integers by the 1.5·2^52 trick (exact for |q| < 2^51, no libm call).
    static Vec3d nearestInteger(const Vec3d& q)
    {
        constexpr double k = 6755399441055744.0;
        return Vec3d((q[0] + k) - k, (q[1] + k) - k, (q[2] + k) - k);
    }

    openvdb::FloatGrid::ConstPtr mGrid;
    BBoxd mBounds;
    bool mFast = false;
    Vec3d mOrigin;
    double mInvDx = 1.0;
    float mInv2dx = 0.5f;
    mutable std::once_flag mGradientOnce;
    mutable openvdb::Vec3SGrid::Ptr mGradient;
};

} // namespace

openvdb::FloatGrid::ConstPtr widenBand(openvdb::FloatGrid::ConstPtr grid, double exactWidth,
                                       double maxMemoryBytes)
{
    if (!grid) fail<ValueError>("level set field: grid is null");
    requireLevelSet(*grid, "terrain");
    const double dx = grid->voxelSize()[0];
    const double width = double(grid->background());
    if (!(exactWidth > width)) return grid;
    const int iterations = int(std::ceil((exactWidth - width) / dx - 1e-4)) + 1;
    // extendBand voxelises active tiles and grows the band layer by layer: the band's voxels
    // (tiles at their full count) grow by about iterations / (2·half width) of the band per
    // layer, ~12 bytes each with the copy, the masks and a layer's new values.
    const double active = double(grid->activeVoxelCount());
    const double halfWidth = std::max(1.0, width / dx);
    const double bytes = active * (1.0 + iterations / halfWidth) * 12.0;
    const double limit = memoryLimitBytes(maxMemoryBytes);
    if (bytes > limit) {
        const openvdb::Index64 tiles = grid->tree().activeTileCount();
        fail<ValueError>("level set '", grid->getName(), "': widening its band by ", iterations,
                         " voxels needs about ", formatBytes(bytes), ", over the ", formatBytes(limit),
                         " allowed", tiles ? " (its " + std::to_string(tiles) +
                         " active tiles count at their full voxel count; a narrow-band level set "
                         "has none)" : std::string(), "; use a coarser voxel size or raise --max-memory");
    }
    openvdb::FloatGrid::Ptr g = extendBand(*grid, iterations);
    // Beyond the widened band the field must keep growing: background = the new width.
    const float bg = float(width + iterations * dx);
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(g->tree());
    leaves.foreach([bg](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
        for (auto it = leaf.beginValueOn(); it; ++it) it.setValue(std::min(std::max(*it, -bg), bg));
    });
    auto tiles = g->tree().beginValueOn(); // active tiles (above the leaves), if any
    tiles.setMaxDepth(openvdb::FloatTree::ValueOnIter::LEAF_DEPTH - 1);
    for (; tiles; ++tiles) tiles.setValue(std::min(std::max(*tiles, -bg), bg));
    openvdb::tools::changeLevelSetBackground(g->tree(), bg);
    return g;
}

FieldPtr levelSetField(openvdb::FloatGrid::ConstPtr grid, double exactWidth, double maxMemoryBytes)
{
    return std::make_shared<LevelSetField>(widenBand(std::move(grid), exactWidth, maxMemoryBytes));
}

} // namespace rockvdb
