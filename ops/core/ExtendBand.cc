// SPDX-License-Identifier: Apache-2.0
#include "ExtendBand.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tree/LeafManager.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace rockvdb {

namespace {

// Godunov's upwind solution of |∇φ| = 1 at a voxel whose smallest neighbour magnitudes along
// x, y and z are a0, a1, a2 (FLT_MAX: none), voxel size h: the largest u with
// Σ max(u − a_i, 0)² = h², trying one, then two, then three neighbours (as
// tools::FastSweeping's sweep kernel).
inline float godunov(float a0, float a1, float a2, float h)
{
    if (a1 < a0) std::swap(a0, a1);
    if (a2 < a1) std::swap(a1, a2);
    if (a1 < a0) std::swap(a0, a1);
    float u = a0 + h;
    if (u <= a1) return u;
    u = 0.5f * (a0 + a1 + std::sqrt(2.0f * h * h - (a0 - a1) * (a0 - a1)));
    if (u <= a2) return u;
    const float s = a0 + a1 + a2;
    const float d = s * s - 3.0f * (a0 * a0 + a1 * a1 + a2 * a2 - h * h);
    return (1.0f / 3.0f) * (s + std::sqrt(std::max(d, 0.0f)));
}

} // namespace

openvdb::FloatGrid::Ptr extendBand(const openvdb::FloatGrid& grid, int layers)
{
    requireLevelSet(grid, "extendBand input");
    using LeafT = openvdb::FloatTree::LeafNodeType;
    openvdb::FloatGrid::Ptr g = grid.deepCopy();
    if (layers <= 0) return g;
    g->tree().voxelizeActiveTiles();
    const float h = float(g->voxelSize()[0]);
    const float bg = g->background();
    // Unknown space reads as ±FLT_MAX (sign kept): never an upwind neighbour, so every update
    // below reads only the band and the layers computed so far.
    constexpr float kFar = std::numeric_limits<float>::max();
    openvdb::tools::changeLevelSetBackground(g->tree(), kFar);
    openvdb::MaskTree known(g->tree(), false, openvdb::TopologyCopy());
    for (int layer = 0; layer < layers; ++layer) {
        openvdb::MaskTree front(known);
        openvdb::tools::dilateActiveValues(front, 1, openvdb::tools::NN_FACE,
                                           openvdb::tools::IGNORE_TILES);
        front.topologyDifference(known);
        // New voxels come in at ±FLT_MAX: the inactive value's sign (the input's side).
        g->tree().topologyUnion(front);
        openvdb::tree::LeafManager<openvdb::MaskTree> frontLeaves(front);
        const size_t n = frontLeaves.leafCount();
        std::vector<LeafT*> leaves(n);
        {
            openvdb::tree::ValueAccessor<openvdb::FloatTree> acc(g->tree());
            for (size_t i = 0; i < n; ++i) leaves[i] = acc.probeLeaf(frontLeaves.leaf(i).origin());
        }
        std::vector<std::vector<float>> next(n);
        // One Jacobi pass over the front: new magnitudes from all six neighbours into next,
        // then written back (reads never see this pass's writes).
        auto pass = [&](bool relax) {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, n), [&](const tbb::blocked_range<size_t>& r) {
                openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(g->tree());
                for (size_t i = r.begin(); i < r.end(); ++i) {
                    const float* d = leaves[i]->buffer().data();
                    const openvdb::Coord o = leaves[i]->origin();
                    std::vector<float>& out = next[i];
                    out.clear();
                    for (auto it = frontLeaves.leaf(i).getValueMask().beginOn(); it; ++it) {
                        const openvdb::Index p = it.pos();
                        const int x = int(p >> 6), y = int((p >> 3) & 7), z = int(p & 7);
                        float nb[6];
                        if (x > 0 && x < 7 && y > 0 && y < 7 && z > 0 && z < 7) {
                            nb[0] = d[p - 64]; nb[1] = d[p + 64];
                            nb[2] = d[p - 8];  nb[3] = d[p + 8];
                            nb[4] = d[p - 1];  nb[5] = d[p + 1];
                        } else {
                            const openvdb::Coord c = o.offsetBy(x, y, z);
                            nb[0] = acc.getValue(c.offsetBy(-1, 0, 0));
                            nb[1] = acc.getValue(c.offsetBy(1, 0, 0));
                            nb[2] = acc.getValue(c.offsetBy(0, -1, 0));
                            nb[3] = acc.getValue(c.offsetBy(0, 1, 0));
                            nb[4] = acc.getValue(c.offsetBy(0, 0, -1));
                            nb[5] = acc.getValue(c.offsetBy(0, 0, 1));
                        }
                        float u = godunov(std::min(std::abs(nb[0]), std::abs(nb[1])),
                                          std::min(std::abs(nb[2]), std::abs(nb[3])),
                                          std::min(std::abs(nb[4]), std::abs(nb[5])), h);
                        if (relax) u = std::min(u, std::abs(d[p]));
                        out.push_back(u);
                    }
                }
            });
            tbb::parallel_for(tbb::blocked_range<size_t>(0, n), [&](const tbb::blocked_range<size_t>& r) {
                for (size_t i = r.begin(); i < r.end(); ++i) {
                    float* d = leaves[i]->buffer().data();
                    const float* u = next[i].data();
                    for (auto it = frontLeaves.leaf(i).getValueMask().beginOn(); it; ++it, ++u) {
                        d[it.pos()] = d[it.pos()] < 0 ? -*u : *u;
                    }
                }
            });
        };
        // First from the layers before (the front's own voxels read FLT_MAX), then twice with
        // the front's values: a voxel whose upwind neighbour lies in its own layer (a wall
        // oblique to the axes) gets the two- or three-neighbour solution.
        pass(false);
        pass(true);
        pass(true);
        known.topologyUnion(front);
    }
    openvdb::tools::changeLevelSetBackground(g->tree(), bg);
    return g;
}

} // namespace rockvdb
