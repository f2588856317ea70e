// SPDX-License-Identifier: Apache-2.0
// rockvdb — the .stacks file: material stacks saved with their parameters, so editing can
// continue later (`vdb_arches --stacks` writes it, `--from-stacks` reads it back).
//
// Layout (little-endian): "RVSTACKS", format version (u32), the parameters as JSON (u32 length,
// UTF-8), the geometry (nx, ny: i32; cell, x0, y0, z0, quantum: f64), the code stream's size
// (u64) and bytes (Stacks.h), one count byte per stack, and an FNV-1a 64 checksum of
// everything before it. Reading checks every size against the file's length before allocating, the checksum and
// the encoding, so a truncated or corrupt file is refused with one line, never half-read.
#pragma once

#include <rockvdb/arches/Stacks.h>

#include <string>

namespace rockvdb {
namespace arches {

struct StackFile
{
    Stacks stacks;
    std::string params; ///< JSON text (the scene that made the stacks)
};

/// @brief The bytes of a .stacks file.
std::string encodeStackFile(const Stacks& stacks, const std::string& params);
/// @brief Parse .stacks bytes. @throw IoError naming @a what for anything malformed.
StackFile decodeStackFile(const std::string& bytes, const std::string& what);

/// @brief Write @a path atomically (temporary file + rename).
void writeStackFile(const std::string& path, const Stacks& stacks, const std::string& params);
/// @brief Read @a path. @throw IoError if missing, unreadable or malformed.
StackFile readStackFile(const std::string& path);

} // namespace arches
} // namespace rockvdb
