// SPDX-License-Identifier: Apache-2.0
// The .stacks file (see StackFile.h).
#include "StackFile.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace rockvdb {
namespace arches {

namespace {

constexpr char kMagic[8] = {'R', 'V', 'S', 'T', 'A', 'C', 'K', 'S'};
constexpr uint32_t kVersion = 1;

uint64_t fnv1a(const char* p, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < n; ++i) {
        h ^= uint8_t(p[i]);
        h *= 1099511628211ull;
    }
    return h;
}

template<typename T>
void put(std::string& out, const T& v)
{
    out.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

// Reads from a byte range, refusing to run past its end.
struct Reader
{
    const std::string& bytes;
    size_t at;
    const std::string& what;

    void need(size_t n, const char* field)
    {
        if (n > bytes.size() - at) fail<IoError>(what, ": truncated .stacks file (", field, " runs past the end)");
    }
    template<typename T>
    T get(const char* field)
    {
        need(sizeof(T), field);
        T v;
        std::memcpy(&v, bytes.data() + at, sizeof(T));
        at += sizeof(T);
        return v;
    }
};

} // namespace

std::string encodeStackFile(const Stacks& stacks, const std::string& params)
{
    static_assert(sizeof(double) == 8, "IEEE doubles");
    const auto& g = stacks.geometry();
    std::string out;
    out.reserve(64 + params.size() + stacks.bytes());
    out.append(kMagic, sizeof kMagic);
    put(out, kVersion);
    put(out, uint32_t(params.size()));
    out += params;
    put(out, int32_t(g.nx));
    put(out, int32_t(g.ny));
    for (double v : {g.cell, g.x0, g.y0, g.z0, g.quantum}) put(out, v);
    put(out, uint64_t(stacks.stream().size()));
    out.append(reinterpret_cast<const char*>(stacks.stream().data()), stacks.stream().size());
    out.append(reinterpret_cast<const char*>(stacks.counts().data()), stacks.counts().size());
    put(out, fnv1a(out.data(), out.size()));
    return out;
}

StackFile decodeStackFile(const std::string& bytes, const std::string& what)
{
    if (bytes.size() < sizeof kMagic || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) {
        fail<IoError>(what, ": not a .stacks file (no RVSTACKS header)");
    }
    if (bytes.size() < sizeof kMagic + 8) fail<IoError>(what, ": truncated .stacks file");
    uint64_t stored;
    std::memcpy(&stored, bytes.data() + bytes.size() - 8, 8);
    if (stored != fnv1a(bytes.data(), bytes.size() - 8)) {
        fail<IoError>(what, ": corrupt .stacks file (checksum mismatch)");
    }
    const std::string body = bytes.substr(0, bytes.size() - 8);
    Reader r{body, sizeof kMagic, what};
    const uint32_t version = r.get<uint32_t>("version");
    if (version != kVersion) fail<IoError>(what, ": .stacks format version ", version, " (this build reads ", kVersion, ")");
    const uint32_t paramBytes = r.get<uint32_t>("parameters");
    r.need(paramBytes, "parameters");
    StackFile f;
    f.params = body.substr(r.at, paramBytes);
    r.at += paramBytes;
    StackGeometry g;
    g.nx = r.get<int32_t>("geometry");
    g.ny = r.get<int32_t>("geometry");
    g.cell = r.get<double>("geometry");
    g.x0 = r.get<double>("geometry");
    g.y0 = r.get<double>("geometry");
    g.z0 = r.get<double>("geometry");
    g.quantum = r.get<double>("geometry");
    try {
        g.validate();
    } catch (const ValueError& e) {
        fail<IoError>(what, ": ", e.what());
    }
    const uint64_t streamBytes = r.get<uint64_t>("stream size");
    // Sizes against what is left, before any allocation.
    const size_t left = body.size() - r.at;
    if (streamBytes > left || g.count() != left - streamBytes) {
        fail<IoError>(what, ": inconsistent .stacks file (", streamBytes, " stream bytes and ", g.count(), " stacks in ", left, " bytes)");
    }
    std::vector<uint8_t> c(body.begin() + std::ptrdiff_t(r.at), body.begin() + std::ptrdiff_t(r.at + streamBytes));
    r.at += streamBytes;
    std::vector<uint8_t> n(body.begin() + std::ptrdiff_t(r.at), body.end());
    try {
        f.stacks = Stacks::fromEncoding(g, std::move(c), std::move(n));
    } catch (const ValueError& e) {
        fail<IoError>(what, ": ", e.what());
    }
    return f;
}

void writeStackFile(const std::string& path, const Stacks& stacks, const std::string& params)
{
    writeFileAtomic(path, encodeStackFile(stacks, params));
}

StackFile readStackFile(const std::string& path)
{
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) {
        fail<IoError>("stacks file: '", path, "' is not a file (missing, a folder or a device)");
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) fail<IoError>("stacks file: cannot open '", path, "'");
    std::stringstream ss;
    ss << in.rdbuf();
    if (in.bad()) fail<IoError>("stacks file: cannot read '", path, "'");
    return decodeStackFile(ss.str(), "stacks file '" + path + "'");
}

} // namespace arches
} // namespace rockvdb
