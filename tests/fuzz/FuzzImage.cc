// SPDX-License-Identifier: Apache-2.0
// Fuzz target: heightfield and relief images (PNG, EXR) through readGrayImage, as
// vdb_heightfield, expressions and the relief maps read them.
#include "FuzzUtil.h"

#include <rockvdb/core/Image.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    using namespace rockvdb;
    const std::string path = fuzz::writeInput(data, size, ".img");
    fuzz::expectClean([&] { (void)readGrayImage(path, "fuzz"); });
    return 0;
}
