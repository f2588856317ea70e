// SPDX-License-Identifier: Apache-2.0
// rockvdb fuzz targets: what every target shares.
//
// A target feeds its bytes to one of our parsers the way a tool does (through a file when the
// parser reads files) and accepts only the library's documented failures: ValueError and
// IoError (one-line messages). Anything else — a crash, a sanitizer report, another exception
// escaping, an allocation over libFuzzer's -malloc_limit_mb — is a finding.
#pragma once

#include <rockvdb/core/Error.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <unistd.h>

namespace rockvdb::fuzz {

/// @brief A file of this process holding @a size bytes, named with @a ext ("" = none); the
/// same path every call (the targets run one input at a time).
inline std::string writeInput(const uint8_t* data, size_t size, const std::string& ext)
{
    const char* dir = std::getenv("TMPDIR");
    const std::string path = std::string(dir && *dir ? dir : "/tmp") + "/rockvdb-fuzz-" +
                             std::to_string(::getpid()) + ext;
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::abort();
    if (size && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
    return path;
}

/// @brief Run @a f, accepting the library's documented errors only.
template<typename F>
void expectClean(F&& f)
{
    try {
        f();
    } catch (const ValueError&) {
    } catch (const IoError&) {
    }
}

} // namespace rockvdb::fuzz
