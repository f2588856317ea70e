// SPDX-License-Identifier: Apache-2.0
// rockvdb — reading rockvdb metadata back from a file (tile files, rock tile sets, chunk
// manifests): every value is checked before anything is sized from it, and a wrong one is
// named with its file and its key in one line,
//   corrupt tile file 't.vdb': rockvdb:tile.blocks[12].planes has 4294967295 entries
// an IoError (a file is invalid: CLI exit 1, Python IOError) whatever check caught it.
#pragma once

#include <rockvdb/core/Error.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <string>

namespace rockvdb {

class Corrupt
{
public:
    /// @a what names the file ("tile file 't.vdb'"); @a root is the key of the whole value
    /// ("rockvdb:tile" for metadata, "" for a file that is the JSON itself).
    Corrupt(std::string what, std::string root) : mWhat(std::move(what)), mRoot(std::move(root)) {}

    const std::string& what() const { return mWhat; }

    /// @brief The full key of a member: key("blocks[3].planes").
    std::string key(const std::string& sub) const
    {
        if (mRoot.empty()) return sub;
        if (sub.empty()) return mRoot;
        return mRoot + (sub[0] == '[' ? "" : ".") + sub;
    }

    /// @brief IoError "corrupt <what>: <key> <problem>".
    [[noreturn]] void fail(const std::string& sub, const std::string& problem) const
    {
        rockvdb::fail<IoError>("corrupt ", mWhat, ": ", key(sub), " ", problem);
    }

    /// @brief Member @a name of object @a j (at @a sub), present.
    const nlohmann::json& at(const nlohmann::json& j, const std::string& sub, const char* name) const
    {
        const std::string k = sub.empty() ? name : sub + "." + name;
        if (!j.is_object()) fail(sub, "is not an object");
        const auto it = j.find(name);
        if (it == j.end()) fail(k, "is missing");
        return *it;
    }

    /// @brief An array of @a lo..hi entries.
    const nlohmann::json& array(const nlohmann::json& j, const std::string& sub, size_t lo,
                                size_t hi) const
    {
        if (!j.is_array()) fail(sub, "is not an array");
        if (j.size() < lo || j.size() > hi) {
            fail(sub, "has " + std::to_string(j.size()) + " entries (expected " + std::to_string(lo) +
                          (hi == lo ? "" : " to " + std::to_string(hi)) + ")");
        }
        return j;
    }

    /// @brief A finite number in [lo, hi].
    double number(const nlohmann::json& j, const std::string& sub, double lo, double hi) const
    {
        if (!j.is_number()) fail(sub, "is not a number (" + shown(j) + ")");
        const double v = j.get<double>();
        if (!std::isfinite(v) || v < lo || v > hi) {
            fail(sub, "has value " + shown(j) + " (expected " + num(lo) + " to " + num(hi) + ")");
        }
        return v;
    }

    /// @brief An integer in [lo, hi].
    int64_t integer(const nlohmann::json& j, const std::string& sub, int64_t lo, int64_t hi) const
    {
        if (!j.is_number_integer()) fail(sub, "is not an integer (" + shown(j) + ")");
        if (j.is_number_unsigned() && j.get<uint64_t>() > uint64_t(INT64_MAX)) {
            fail(sub, "has value " + shown(j) + " (expected " + std::to_string(lo) + " to " +
                          std::to_string(hi) + ")");
        }
        const int64_t v = j.get<int64_t>();
        if (v < lo || v > hi) {
            fail(sub, "has value " + shown(j) + " (expected " + std::to_string(lo) + " to " +
                          std::to_string(hi) + ")");
        }
        return v;
    }

    /// @brief A string.
    std::string string(const nlohmann::json& j, const std::string& sub) const
    {
        if (!j.is_string()) fail(sub, "is not a string (" + shown(j) + ")");
        return j.get<std::string>();
    }

    /// @brief sub + "[i]".
    static std::string item(const std::string& sub, size_t i) { return sub + "[" + std::to_string(i) + "]"; }

private:
    static std::string num(double v)
    {
        std::ostringstream os;
        os << v;
        return os.str();
    }
    // A value as it reads, cut short (a flipped bit can make a string of anything).
    static std::string shown(const nlohmann::json& j)
    {
        std::string s = j.dump(-1, ' ', true, nlohmann::json::error_handler_t::replace);
        if (s.size() > 40) s = s.substr(0, 37) + "...";
        return s;
    }

    std::string mWhat, mRoot;
};

} // namespace rockvdb
