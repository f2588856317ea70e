// SPDX-License-Identifier: Apache-2.0
#include "Json.h"

#include <rockvdb/core/Error.h>

#include <cstdint>
#include <fstream>
#include <iterator>
#include <sys/stat.h>

namespace rockvdb {

using nlohmann::json;

namespace {

struct TooDeep {};

json parseLimited(const std::string& text)
{
    const json::parser_callback_t limit = [](int depth, json::parse_event_t, json&) {
        if (depth > kMaxJsonDepth) throw TooDeep{};
        return true;
    };
    return json::parse(text, limit);
}

// "[json.exception.parse_error.101] parse error at line 1, column 2: ..." -> "parse error at ..."
std::string jsonMessage(const json::exception& e)
{
    std::string m = e.what();
    if (m.rfind("[json.exception.", 0) == 0) {
        const size_t close = m.find("] ");
        if (close != std::string::npos) m = m.substr(close + 2);
    }
    return m;
}

} // namespace

json parseJson(const std::string& text, const std::string& what)
{
    try {
        return parseLimited(text);
    } catch (const TooDeep&) {
        fail<ValueError>(what, ": JSON nested deeper than ", kMaxJsonDepth, " levels");
    } catch (const json::exception& e) {
        fail<ValueError>(what, ": malformed JSON (", jsonMessage(e), ")");
    }
}

json parseJsonOrDiscarded(const std::string& text)
{
    try {
        return parseLimited(text);
    } catch (const TooDeep&) {
    } catch (const json::exception&) {
    }
    return json(json::value_t::discarded);
}

namespace {

// @a text with every byte that does not start a well-formed UTF-8 sequence replaced by U+FFFD:
// a JSON string must be valid UTF-8 (dump() throws on the first bad byte otherwise), and
// metadata read from a file can hold anything.
std::string validUtf8(const std::string& text)
{
    std::string out;
    out.reserve(text.size());
    const auto* b = reinterpret_cast<const unsigned char*>(text.data());
    const size_t n = text.size();
    for (size_t i = 0; i < n;) {
        const unsigned char c = b[i];
        size_t len = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
        bool ok = len > 0 && i + len <= n;
        for (size_t k = 1; ok && k < len; ++k) ok = (b[i + k] & 0xc0) == 0x80;
        if (ok && len > 1) {
            // No overlong forms, no surrogates, nothing past U+10FFFF.
            uint32_t cp = c & (0xff >> (len + 1));
            for (size_t k = 1; k < len; ++k) cp = (cp << 6) | (b[i + k] & 0x3f);
            static const uint32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
            ok = cp >= least[len] && cp <= 0x10ffff && !(cp >= 0xd800 && cp <= 0xdfff);
        }
        if (ok) {
            out.append(text, i, len);
            i += len;
        } else {
            out += "\xef\xbf\xbd";
            ++i;
        }
    }
    return out;
}

} // namespace

json jsonOrText(const std::string& text)
{
    json j = parseJsonOrDiscarded(text);
    return j.is_discarded() ? json(validUtf8(text)) : j;
}

json readJsonFile(const std::string& path)
{
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) fail<IoError>("cannot read '", path, "': no such file");
    std::ifstream f(path);
    if (!f) fail<IoError>("cannot read '", path, "'");
    const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    return parseJson(text, "'" + path + "'");
}

std::string jsonText(const json& j)
{
    return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

} // namespace rockvdb
