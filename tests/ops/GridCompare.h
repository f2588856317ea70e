// SPDX-License-Identifier: Apache-2.0
// Shared by the C++ tests: bitwise equality of two level-set grids.
#pragma once

#include <openvdb/openvdb.h>

#include <cstring>

namespace rockvdb {
namespace test {

/// @brief Same leaves, masks, value bits, background and tiles (inside fill included).
inline bool bitwiseEqual(const openvdb::FloatGrid& a, const openvdb::FloatGrid& b)
{
    if (a.tree().leafCount() != b.tree().leafCount()) return false;
    if (a.activeVoxelCount() != b.activeVoxelCount()) return false;
    if (a.background() != b.background()) return false;
    auto bacc = b.getConstAccessor();
    for (auto leaf = a.tree().cbeginLeaf(); leaf; ++leaf) {
        const auto* other = bacc.probeConstLeaf(leaf->origin());
        if (!other) return false;
        if (leaf->getValueMask() != other->getValueMask()) return false;
        if (std::memcmp(leaf->buffer().data(), other->buffer().data(), 512 * sizeof(float)) != 0)
            return false;
    }
    for (auto it = a.tree().cbeginValueAll(); it; ++it) {
        if (it.isVoxelValue()) continue;
        if (bacc.getValue(it.getCoord()) != *it) return false;
    }
    return true;
}

} // namespace test
} // namespace rockvdb
