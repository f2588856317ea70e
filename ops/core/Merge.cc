#include "Merge.h"

#include <cstdio>
#include <string>

#include <rockvdb/core/Error.h>

#include <openvdb/tools/SignedFloodFill.h>

namespace rockvdb {

openvdb::FloatGrid::Ptr mergeChunks(const std::vector<openvdb::FloatGrid::ConstPtr>& chunks)
{
    using openvdb::FloatGrid;
    using LeafT = FloatGrid::TreeType::LeafNodeType;
    if (chunks.empty()) fail<ValueError>("merge: no chunks");
    for (const auto& c : chunks) {
        if (!c) fail<ValueError>("merge: a chunk is null");
    }
    const FloatGrid& first = *chunks.front();
    auto out = first.deepCopy();
    auto& tree = out->tree();
    for (size_t i = 1; i < chunks.size(); ++i) {
        const FloatGrid& c = *chunks[i];
        if (c.getName() != first.getName()) {
            fail<ValueError>("merge: chunk ", i + 1, " holds grid '", c.getName(), "', not '",
                             first.getName(), "'");
        }
        if (c.transform() != first.transform()) {
            fail<ValueError>("merge: grid '", c.getName(), "' of chunk ", i + 1,
                             " has another transform (voxel size or origin) than chunk 1");
        }
        if (c.getGridClass() != first.getGridClass() || c.background() != first.background()) {
            fail<ValueError>("merge: grid '", c.getName(), "' of chunk ", i + 1,
                             " has another class or background than chunk 1");
        }
        for (auto leaf = c.tree().cbeginLeaf(); leaf; ++leaf) {
            LeafT* dst = tree.probeLeaf(leaf->origin());
            if (!dst) {
                tree.addLeaf(new LeafT(*leaf));
                continue;
            }
            for (auto v = leaf->cbeginValueOn(); v; ++v) {
                const openvdb::Index n = v.pos();
                if (dst->isValueOn(n) && dst->getValue(n) != *v) {
                    const auto ijk = v.getCoord();
                    // Nine significant digits: two floats that differ always print apart.
                    auto exact = [](float x) {
                        char buf[32];
                        std::snprintf(buf, sizeof buf, "%.9g", double(x));
                        return std::string(buf);
                    };
                    fail<ValueError>("merge: chunks disagree on grid '", c.getName(), "' at voxel (",
                                     ijk.x(), ", ", ijk.y(), ", ", ijk.z(), "): ",
                                     exact(dst->getValue(n)), " vs ", exact(*v), " (not chunks of one bake?)");
                }
                dst->setValueOn(n, *v);
            }
        }
    }
    if (out->getGridClass() == openvdb::GRID_LEVEL_SET) {
        // Tiles above the leaves take the sign of their neighbours; the leaves keep the
        // signs the bake gave their inactive voxels.
        openvdb::tools::signedFloodFill(tree, /*threaded=*/true, /*grainSize=*/1, /*minLevel=*/1);
    }
    return out;
}

} // namespace rockvdb
