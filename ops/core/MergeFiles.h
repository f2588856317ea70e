// SPDX-License-Identifier: Apache-2.0
// rockvdb — merging chunk files into the whole bake: the file side of Merge.h, shared by
// vdb_merge and rockvdb.distributed (which checks its chunk records with the same checksum).
#pragma once

#include <rockvdb/core/StageResult.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace rockvdb {

/// @brief CRC-32 (zlib's, as Python's zlib.crc32) and size of a file: what a chunk manifest
/// and rockvdb.distributed's chunk records hold. @throw IoError when unreadable.
std::pair<uint32_t, uint64_t> fileChecksum(const std::string& path);

/// @brief The chunk files a manifest of rockvdb.distributed lists (relative to its folder),
/// in chunk order, each checked against its CRC-32 and size: a missing, half-written or
/// damaged chunk is named, never merged. @throw ValueError / IoError.
std::vector<std::string> manifestChunks(const std::string& path);

/// @brief Merge chunk files (one read at a time; "-" = stdin) grid by grid, matched by name.
/// When every grid's chunks are the N chunks i/N of one bake, all N are required and the
/// merged grid carries that bake's own provenance (it replays to the same grid in one run);
/// otherwise generator @a tool with @a toolParams and the sources listed. grids: in the first
/// file's order; report: a line per grid.
/// @throw ValueError for files that are not chunks of one bake.
StageResult mergeChunkFiles(const std::vector<std::string>& inputs, const std::string& tool,
                            const nlohmann::json& toolParams);

} // namespace rockvdb
