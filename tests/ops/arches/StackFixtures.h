// SPDX-License-Identifier: Apache-2.0
// Shared by the material-stack tests (TestArches.cc, TestArchesEdits.cc): a stack geometry and
// random stacks of every material.
#pragma once

#include <rockvdb/arches/Stacks.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/Task.h>

namespace rockvdb {
namespace test {

inline arches::StackGeometry stackGeometry(int nx, int ny, double cell, double quantum = 0.01)
{
    arches::StackGeometry g;
    g.nx = nx;
    g.ny = ny;
    g.cell = cell;
    g.quantum = quantum;
    return g;
}

/// Random stacks: up to 6 layers of random materials and thicknesses, 0.5 m cells.
inline arches::Stacks randomStacks(uint64_t seed, int n = 9)
{
    using namespace arches;
    using random::uniform;
    Task task;
    return Stacks::build(stackGeometry(n, n, 0.5, 0.01), [&](int i, int j, std::vector<Layer>& layers) {
        const uint64_t key = uint64_t(j) * 1000 + uint64_t(i);
        const int count = int(uniform(seed, uint64_t(0), key) * 6.0);
        for (int l = 0; l < count; ++l) {
            layers.push_back(Layer{Material(int(uniform(seed, uint64_t(1 + 2 * l), key) * 5.0) % 5),
                                   uint32_t(1 + uniform(seed, uint64_t(2 + 2 * l), key) * 150.0)});
        }
    }, task);
}

} // namespace test
} // namespace rockvdb
