// SPDX-License-Identifier: Apache-2.0
// Fuzz target: .vdb bytes through rockvdb's reader (readGrids: the probe in a child process,
// then the parse), then what the reading tools do next with the grids (find the level set,
// read provenance).
#include "FuzzUtil.h"

#include <rockvdb/core/VdbIO.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    using namespace rockvdb;
    const std::string path = fuzz::writeInput(data, size, ".vdb");
    fuzz::expectClean([&] {
        const auto grids = readGrids(path);
        for (const auto& g : *grids) {
            if (g) (void)provenance(*g);
        }
        (void)findLevelSet(*grids, "", path);
    });
    return 0;
}
