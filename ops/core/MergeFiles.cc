// Chunk files into the whole bake (see MergeFiles.h).
#include "MergeFiles.h"

#include <rockvdb/core/Chunks.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/core/Merge.h>
#include <rockvdb/core/VdbIO.h>

#include <zlib.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

namespace rockvdb {

using nlohmann::json;

std::pair<uint32_t, uint64_t> fileChecksum(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in) fail<IoError>("checksum: cannot open ", path);
    uLong crc = crc32(0L, Z_NULL, 0);
    uint64_t size = 0;
    std::vector<char> buf(1 << 20);
    while (in) {
        in.read(buf.data(), std::streamsize(buf.size()));
        const std::streamsize got = in.gcount();
        if (got <= 0) break;
        crc = crc32(crc, reinterpret_cast<const Bytef*>(buf.data()), uInt(got));
        size += uint64_t(got);
    }
    return {uint32_t(crc), size};
}

std::vector<std::string> manifestChunks(const std::string& path)
{
    std::ifstream in(path);
    if (!in) fail<IoError>("merge: cannot open manifest ", path);
    const json m = parseJsonOrDiscarded(
        std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()));
    if (!m.is_object() || m.value("format", "") != "rockvdb-chunks" || !m.contains("files") ||
        !m["files"].is_array() || !m.contains("count") || !m["count"].is_number_integer()) {
        fail<ValueError>("merge: ", path, " is not a rockvdb chunk manifest");
    }
    const auto dir = std::filesystem::path(path).parent_path();
    const long long count = m["count"].get<long long>();
    std::vector<std::string> files(size_t(std::max(0LL, count)));
    std::set<long long> seen;
    for (const auto& f : m["files"]) {
        if (!f.is_object() || !f.contains("index") || !f["index"].is_number_integer() ||
            !f.contains("file") || !f["file"].is_string() || !f.contains("crc32") ||
            !f["crc32"].is_number_unsigned() || !f.contains("bytes") || !f["bytes"].is_number_unsigned()) {
            fail<ValueError>("merge: ", path, ": a chunk entry lacks index, file, crc32 or bytes");
        }
        const long long i = f["index"].get<long long>();
        if (i < 0 || i >= count || !seen.insert(i).second) {
            fail<ValueError>("merge: ", path, ": chunk index ", i, " is outside [0, ", count, ") or listed twice");
        }
        const std::string file = (dir / f["file"].get<std::string>()).string();
        if (!std::filesystem::exists(file)) {
            fail<IoError>("merge: chunk ", i, "/", count, " (", file, ") is missing: rerun the bake "
                          "with the same --chunk-dir to recompute it");
        }
        const auto [crc, size] = fileChecksum(file);
        if (crc != f["crc32"].get<uint32_t>() || size != f["bytes"].get<uint64_t>()) {
            fail<IoError>("merge: chunk ", i, "/", count, " (", file, ") does not match its checksum "
                          "in the manifest (damaged or half written): rerun the bake with the same "
                          "--chunk-dir to recompute it");
        }
        files[size_t(i)] = file;
    }
    if (seen.size() != files.size()) {
        fail<ValueError>("merge: ", path, " lists ", seen.size(), " of its ", count, " chunks");
    }
    return files;
}

StageResult mergeChunkFiles(const std::vector<std::string>& inputs, const std::string& tool,
                            const json& toolParams)
{
    if (inputs.empty()) fail<ValueError>("merge: give chunk files or --manifest");
    if (std::count(inputs.begin(), inputs.end(), "-") > 1) {
        fail<ValueError>("merge: stdin ('-') can be given only once");
    }
    StageResult out;
    std::vector<std::string> names; // grid order of the first chunk
    std::map<std::string, ChunkMerger> mergers;
    std::map<std::string, json> sources;
    // Per grid: the whole bake's generator and parameters, and the chunks i/N seen.
    struct Whole { std::string generator; json params; std::map<int, size_t> chunks; int count = -1; bool ok = true; };
    std::map<std::string, Whole> whole;
    for (size_t i = 0; i < inputs.size(); ++i) {
        auto grids = readGrids(inputs[i]);
        // The file's grids first: chunks of one bake hold the same grids.
        std::vector<openvdb::FloatGrid::Ptr> floats;
        std::vector<std::string> here;
        for (const auto& g : *grids) {
            auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
            if (!f) {
                fail<ValueError>("merge: grid '", g->getName(), "' in ", inputs[i],
                                 " is not a float grid");
            }
            if (std::count(here.begin(), here.end(), f->getName())) {
                fail<ValueError>("merge: ", inputs[i], " holds two grids named '",
                                 f->getName(), "'");
            }
            here.push_back(f->getName());
            floats.push_back(f);
        }
        if (i == 0) {
            names = here;
            if (names.empty()) fail<ValueError>("merge: ", inputs[i], " holds no grids");
        } else {
            std::vector<std::string> a = names, b = here;
            std::sort(a.begin(), a.end());
            std::sort(b.begin(), b.end());
            if (a != b) {
                fail<ValueError>("merge: ", inputs[i], " holds other grids than ", inputs[0],
                                 " (chunks of one bake hold the same grids)");
            }
        }
        for (const auto& f : floats) {
            json src = {{"file", inputs[i]}};
            Whole& w = whole[f->getName()];
            std::string chunk;
            if (auto p = provenance(*f)) {
                src["generator"] = p->generator;
                src["params"] = jsonOrText(p->params);
                const json params = wholeBakeParams(src["params"], &chunk);
                if (i == 0) {
                    w.generator = p->generator;
                    w.params = params;
                } else if (w.generator != p->generator || w.params != params) {
                    w.ok = false;
                }
            }
            // The stages' own parser: "i/N" as the chunk row reads it (an edited or
            // foreign value makes the file a plain chunk, merged with its sources listed).
            ChunkSpec spec;
            try {
                spec = ChunkSpec::parse("", chunk, "merge");
            } catch (const ValueError&) {
            }
            if (!spec.active()) {
                w.ok = false;
            } else {
                if (w.count >= 0 && w.count != spec.count) w.ok = false;
                w.count = spec.count;
                if (w.chunks.count(spec.index)) {
                    fail<ValueError>("merge: ", inputs[i], " and ", inputs[w.chunks[spec.index]],
                                     " are both chunk ", chunk, " of one bake");
                }
                w.chunks[spec.index] = i;
            }
            sources[f->getName()].push_back(src);
            mergers[f->getName()].take(*f);
        }
        grids.reset(); // (one chunk in memory at a time)
    }
    for (const auto& name : names) {
        auto merged = mergers[name].finish();
        const Whole& w = whole[name];
        if (w.ok && w.count > 0) {
            // The N chunks of one bake: all of them, and the bake's own provenance.
            if (int(w.chunks.size()) != w.count) {
                std::string missing;
                for (int k = 0, shown = 0; k < w.count && shown < 8; ++k) {
                    if (w.chunks.count(k)) continue;
                    missing += (missing.empty() ? "" : ", ") + std::to_string(k);
                    ++shown;
                }
                fail<ValueError>("merge: grid '", name, "' has ", w.chunks.size(), " of the ",
                                 w.count, " chunks of its bake; missing chunk(s) ", missing,
                                 int(w.count - w.chunks.size()) > 8 ? ", ..." : "");
            }
            stampProvenance(*merged, w.generator,
                            jsonText(w.params));
        } else {
            json params = toolParams;
            params["sources"] = sources[name];
            stampProvenance(*merged, tool,
                            jsonText(params));
        }
        out.report.push_back(name + ": " + std::to_string(merged->activeVoxelCount()) + " active voxels");
        out.grids.push_back(merged);
    }
    return out;
}

} // namespace rockvdb
