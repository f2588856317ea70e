// SPDX-License-Identifier: Apache-2.0
// rockvdb — JSON helpers every layer shares: bounded parsing with one-line messages, files,
// text that should be JSON, and the one way JSON is written out (provenance, tile files, stats).
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace rockvdb {

/// @brief Read a JSON file (parseJson). @throw IoError / ValueError.
nlohmann::json readJsonFile(const std::string& path);

/// Deepest nesting of objects and arrays accepted in any JSON we read: whatever walks a
/// value recursively (expressions, dump(), the schema) stays far from the stack's end.
constexpr int kMaxJsonDepth = 200;

/// @brief Parse JSON text with nesting limited to kMaxJsonDepth.
/// @throw ValueError "<what>: malformed JSON (...)" or "<what>: JSON nested deeper than 200
/// levels", one line, without nlohmann's "[json.exception...]" prefix.
nlohmann::json parseJson(const std::string& text, const std::string& what);

/// @brief As parseJson, but malformed or too deep text gives a discarded value.
nlohmann::json parseJsonOrDiscarded(const std::string& text);

/// @brief Text that should hold JSON (a file's provenance), parsed; the text itself (a JSON
/// string) when it is malformed or too deep, so what embeds it stays valid JSON.
nlohmann::json jsonOrText(const std::string& text);

/// @brief @a j as compact JSON text, bytes that are not UTF-8 replaced by U+FFFD (dump()
/// would throw on them): what provenance, tile files and stats are written as.
std::string jsonText(const nlohmann::json& j);

} // namespace rockvdb
