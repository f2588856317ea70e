// SPDX-License-Identifier: Apache-2.0
// rockvdb — what the vdb_* conventions' own files share (not for the tools: they use Cli.h).
// Cli.cc: Tool, run() and the small helpers; Signals.cc: Ctrl-C, SIGTERM and the watchdog;
// Options.cc: a table's rows as CLI11 options and --params JSON; Distribute.cc: chunked and
// cluster bakes handed to rockvdb.distributed; TaskBar.cc: the progress bar.
#pragma once

#include <rockvdb/core/Schema.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <string>

namespace rockvdb {
namespace cli {

/// @brief SIGINT / SIGTERM set the flag every Task checks and start a 0.8 s watchdog that
/// ends a run that cannot check (its temporaries removed, "<tool>: error: interrupted;
/// nothing written", exit 130); SIGPIPE is ignored; a cancel stops outputs from landing.
void installInterruptHandlers(const std::string& tool, bool clearLine);
/// @brief True once Ctrl-C or SIGTERM came.
bool sigintSeen();
/// @brief Stop the watchdog (the run is over, or answered the signal itself).
void cancelWatchdog();

/// @brief A row's value as the CLI spells it ("1,2,3" for lists), and back.
std::string cliText(const nlohmann::json& v);
nlohmann::json fromText(ParamType type, const std::string& text);

/// @brief The --params formatter: JSON files whose keys name options ("voxel-size") or
/// subcommands ({"tiles": {...}}); unknown keys are errors naming the closest option.
std::shared_ptr<CLI::Config> makeConfigJson(CLI::App* app);
/// @brief Every option's value (defaults included) of @a app as JSON: a run's provenance.
nlohmann::json appToJson(const CLI::App* app);

} // namespace cli
} // namespace rockvdb
