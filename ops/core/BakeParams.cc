// SPDX-License-Identifier: Apache-2.0
#include "BakeParams.h"

namespace rockvdb {

BakeSettings BakeParams::settings(double voxelSizeIfUnset, double halfWidthIfUnset) const
{
    BakeSettings s;
    s.voxelSize = voxelSize.value_or(voxelSizeIfUnset);
    s.halfWidth = halfWidth.value_or(halfWidthIfUnset);
    s.renormalize = renormalizeFromString(renormalize);
    s.trackerSteps = trackerSteps;
    if (region) {
        const auto& r = *region;
        s.region = BBoxd(Vec3d(r[0], r[1], r[2]), Vec3d(r[3], r[4], r[5]));
    }
    s.maxMemoryBytes = maxMemoryGB * 1e9;
    s.chunk = chunking.spec("bake");
    s.validate();
    return s;
}

const Schema<FieldBakeParams>& fieldBakeSchema()
{
    static const Schema<FieldBakeParams> s = [] {
        Schema<FieldBakeParams> t("bake", "Bake a field into a narrow-band level set.");
        addBakeRows(t, &FieldBakeParams::bake, defaultVoxelSize(), defaultHalfWidth());
        return t;
    }();
    return s;
}

} // namespace rockvdb
