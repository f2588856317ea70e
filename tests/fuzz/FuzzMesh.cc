// SPDX-License-Identifier: Apache-2.0
// Fuzz target: OBJ / STL / PLY through readMesh, then the closed-surface check the mesh tools
// make. The first byte picks the format (readMesh goes by extension); the rest is the file.
#include "FuzzUtil.h"

#include <rockvdb/core/Mesh.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    using namespace rockvdb;
    if (size == 0) return 0;
    static const char* const kExt[] = {".obj", ".stl", ".ply"};
    const std::string path = fuzz::writeInput(data + 1, size - 1, kExt[data[0] % 3]);
    fuzz::expectClean([&] {
        const Mesh mesh = readMesh(path, UpAxis::Y);
        requireClosed(mesh, "fuzz");
    });
    return 0;
}
