// SPDX-License-Identifier: Apache-2.0
#include "Merge.h"

#include <cstdio>
#include <string>

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Error.h>

#include <openvdb/tools/SignedFloodFill.h>

namespace rockvdb {

openvdb::FloatGrid::Ptr mergeChunks(const std::vector<openvdb::FloatGrid::ConstPtr>& chunks)
{
    if (chunks.empty()) fail<ValueError>("merge: no chunks");
    ChunkMerger merger;
    for (const auto& c : chunks) {
        if (!c) fail<ValueError>("merge: a chunk is null");
        merger.add(*c);
    }
    return merger.finish();
}

void ChunkMerger::add(const openvdb::FloatGrid& c)
{
    auto copy = c.deepCopy();
    take(*copy);
}

void ChunkMerger::take(openvdb::FloatGrid& c)
{
    using LeafT = openvdb::FloatGrid::TreeType::LeafNodeType;
    ++mCount;
    if (!mOut) {
        mOut = c.copyWithNewTree();
        mOut->tree().merge(c.tree(), openvdb::MERGE_NODES);
        return;
    }
    const openvdb::FloatGrid& first = *mOut;
    const size_t i = mCount - 1;
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
    auto& tree = mOut->tree();
    // Leaves both hold (chunks not cut on leaf faces) unite voxel by voxel here; every other
    // node of the chunk moves over whole (MERGE_NODES keeps this tree's leaf where both have
    // one, and puts the chunk's nodes where this tree has only a tile).
    for (auto leaf = c.tree().cbeginLeaf(); leaf; ++leaf) {
        LeafT* dst = tree.probeLeaf(leaf->origin());
        if (!dst) continue;
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
    tree.merge(c.tree(), openvdb::MERGE_NODES);
}

openvdb::FloatGrid::Ptr ChunkMerger::finish()
{
    if (mOut && mOut->getGridClass() == openvdb::GRID_LEVEL_SET) {
        // Tiles above the leaves take the sign of their neighbours; the leaves keep the
        // signs the bake gave their inactive voxels. A chunk's own inside tiles were filled
        // within its box only (a solid reaching over the box's faces has no leaves there):
        // the fill of the merged tree classifies every tile again.
        openvdb::tools::signedFloodFill(mOut->tree(), /*threaded=*/true, /*grainSize=*/1,
                                        /*minLevel=*/1);
    }
    return mOut;
}

nlohmann::json wholeBakeParams(const nlohmann::json& params, std::string* chunk)
{
    nlohmann::json out = params;
    if (chunk) chunk->clear();
    const ChunkParams whole; // the rows' defaults (addChunkRows)
    auto reset = [&](nlohmann::json& o) {
        if (!o.is_object()) return;
        for (const auto& [key, value] : {std::pair{ChunkParams::kChunkRow, &whole.chunk},
                                         std::pair{ChunkParams::kChunksRow, &whole.chunks}}) {
            auto it = o.find(key);
            if (it == o.end() || !it->is_string()) continue;
            if (chunk && key == ChunkParams::kChunkRow && !it->get<std::string>().empty()) {
                *chunk = it->get<std::string>();
            }
            *it = *value;
        }
    };
    reset(out);
    if (out.is_object()) {
        for (auto it = out.begin(); it != out.end(); ++it) reset(*it);
    }
    return out;
}

} // namespace rockvdb
