// SPDX-License-Identifier: Apache-2.0
// rockvdb — .vdb input/output, provenance metadata and OpenVDB start-up.
#pragma once

#include <openvdb/openvdb.h>

#include <optional>
#include <string>

namespace rockvdb {

/// @brief The library version ("0.1.0").
const char* version();

/// @brief openvdb::initialize() once (thread-safe; every entry point calls it).
void initialize();

/// @name Provenance: every grid written carries rockvdb:version, rockvdb:generator (tool or
/// op name) and rockvdb:params (the complete parameter set as JSON, seed included).
/// @{
struct Provenance
{
    std::string version, generator, params;
};
void stampProvenance(openvdb::GridBase& grid, const std::string& generator,
                     const std::string& paramsJson);
std::optional<Provenance> provenance(const openvdb::GridBase& grid);
/// @}

/// @brief Write @a grids to @a path atomically (temporary file in the same folder, then
/// rename), Blosc + active-mask compressed. "-" writes to stdout (refused on a terminal).
/// Attribute grids are written first and level sets last ('surface' the very last), so tools
/// that take the most recently read grid (vdb_tool) find the level set.
/// @throw IoError when the folder is missing or unwritable; nothing is left behind.
void writeGrids(const std::string& path, const openvdb::GridCPtrVec& grids);

/// @brief Read every grid of @a path ("-" = stdin), fully loaded (no delayed loading). The
/// bytes are parsed first in a child process capped in memory and CPU time (a corrupt file
/// can crash OpenVDB's reader, ask it for gigabytes or loop it for ever), unless they are
/// bytes writeGrids serialised in this process (same size and content UUID, which matches).
/// @throw IoError for a missing, non-VDB, truncated or corrupt file; Interrupted when the
/// check given to setReadInterrupt says so while the child parses.
openvdb::GridPtrVecPtr readGrids(const std::string& path);

/// @brief How many reads this process has checked in a child so far (tests).
size_t readsChecked();

/// @brief A check readGrids polls every 50 ms while its child parses: true gives up (the
/// child is killed, Interrupted thrown). Python's Ctrl-C; null (the default) never gives up.
void setReadInterrupt(bool (*check)());

/// @brief Find grid @a name in @a grids and check it is a float level set. An empty @a name
/// takes 'surface', or else the file's only float level set.
/// @throw ValueError naming the grids present, the grid type or the class found.
openvdb::FloatGrid::Ptr findLevelSet(const openvdb::GridPtrVec& grids, const std::string& name,
                                     const std::string& source);

/// @brief readGrids + findLevelSet.
openvdb::FloatGrid::Ptr readLevelSet(const std::string& path,
                                     const std::string& name = "surface");

/// @brief Check that @a grid is a well-formed float level set (ValueError otherwise).
void requireLevelSet(const openvdb::GridBase& grid, const std::string& what);

/// @brief IoError unless @a path can be created: its folder exists and is writable, and it is
/// not a folder itself. Tools call it before any work so a bad -o fails fast.
void requireWritable(const std::string& path);

/// @brief Unlink every temporary file written and not yet renamed over its target.
/// Async-signal-safe: a signal handler that ends the process calls it, so nothing is left.
void removePendingTemps();

/// @brief While one is open, every write of this process (writeGrids, writeFileAtomic and
/// the writers built on them) lands with the others of the batch or not at all: each output
/// is encoded and written to its temporary file beside its target at once (so a full disk
/// or a bad folder fails there), stdout's bytes are kept; commit() then writes stdout and
/// renames every temporary over its target. A batch closed without commit() (an error, a
/// Ctrl-C) removes its temporaries: no output of the run is written, none replaced. One
/// batch at a time, opened and committed on one thread (the CLI opens one around each run).
class OutputBatch
{
public:
    OutputBatch();
    ~OutputBatch();
    OutputBatch(const OutputBatch&) = delete;
    OutputBatch& operator=(const OutputBatch&) = delete;
    /// @throw Interrupted when the commit check says so (nothing is renamed then).
    void commit();
};

/// @brief A check made just before a finished temporary file is renamed over its target:
/// when it returns true the temporary is removed and Interrupted thrown, so a cancel that
/// comes during a write replaces nothing. The CLI installs its Ctrl-C flag; null = none.
void setCommitCheck(bool (*cancelled)());

/// @brief Write @a bytes to @a path atomically (temporary file + rename); "-" = stdout.
void writeFileAtomic(const std::string& path, const std::string& bytes);

} // namespace rockvdb
