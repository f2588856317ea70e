#include "GridField.h"

#include "Error.h"
#include "VdbIO.h"

#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tools/FastSweeping.h>
#include <openvdb/tools/Interpolation.h>

#include <cmath>

namespace rockvdb {

namespace {

class LevelSetField final : public Field
{
public:
    explicit LevelSetField(openvdb::FloatGrid::Ptr g) : mGrid(std::move(g))
    {
        const openvdb::CoordBBox bb = mGrid->evalActiveVoxelBoundingBox();
        mBounds = BBoxd(mGrid->indexToWorld(bb.min()), mGrid->indexToWorld(bb.max()));
    }

    void evalBatch(const Batch& b, float* out) const override
    {
        auto acc = mGrid->getConstAccessor();
        const openvdb::math::Transform& xf = mGrid->transform();
        for (int i = 0; i < b.n; ++i) {
            const Vec3d ijk = xf.worldToIndex(Vec3d(b.x[i], b.y[i], b.z[i]));
            out[i] = openvdb::tools::BoxSampler::sample(acc, ijk);
        }
    }
    BBoxd bounds() const override { return mBounds; }

private:
    openvdb::FloatGrid::Ptr mGrid;
    BBoxd mBounds;
};

} // namespace

FieldPtr levelSetField(openvdb::FloatGrid::ConstPtr grid, double exactWidth)
{
    if (!grid) fail<ValueError>("level set field: grid is null");
    requireLevelSet(*grid, "terrain");
    const double dx = grid->voxelSize()[0];
    const double width = double(grid->background());
    openvdb::FloatGrid::Ptr g = grid->deepCopy();
    if (exactWidth > width) {
        const int iterations = int(std::ceil((exactWidth - width) / dx)) + 1;
        g = openvdb::tools::dilateSdf(*grid, iterations);
        // Beyond the widened band the field must keep growing: background = the new width.
        const float bg = float(width + iterations * dx);
        for (auto it = g->beginValueOn(); it; ++it) {
            it.setValue(std::min(std::max(*it, -bg), bg));
        }
        openvdb::tools::changeLevelSetBackground(g->tree(), bg);
    }
    return std::make_shared<LevelSetField>(g);
}

} // namespace rockvdb
