// SPDX-License-Identifier: Apache-2.0
// Chunk files into the whole bake (see MergeFiles.h).
#include "MergeFiles.h"

#include <rockvdb/core/Chunks.h>
#include <rockvdb/core/Corrupt.h>
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
    if (!m.is_object() || m.value("format", "") != "rockvdb-chunks") {
        fail<ValueError>("merge: ", path, " is not a rockvdb chunk manifest");
    }
    // Every value checked before anything is sized from it (issue 40): the chunk count
    // against the entries the manifest lists.
    const Corrupt c("chunk manifest '" + path + "'", "");
    const json& files = c.array(c.at(m, "", "files"), "files", 1, size_t(1) << 20);
    const int64_t count = c.integer(c.at(m, "", "count"), "count", 1, int64_t(1) << 20);
    if (count != int64_t(files.size())) {
        c.fail("files", "lists " + std::to_string(files.size()) + " of the " + std::to_string(count) +
                            " chunks its count says");
    }
    const auto dir = std::filesystem::path(path).parent_path();
    std::vector<std::string> out(static_cast<size_t>(count));
    std::set<int64_t> seen;
    for (size_t k = 0; k < files.size(); ++k) {
        const std::string key = Corrupt::item("files", k);
        const json& f = files[k];
        const int64_t i = c.integer(c.at(f, key, "index"), key + ".index", 0, count - 1);
        if (!seen.insert(i).second) c.fail(key + ".index", "lists chunk " + std::to_string(i) + " twice");
        const std::string name = c.string(c.at(f, key, "file"), key + ".file");
        const uint32_t crc = uint32_t(c.integer(c.at(f, key, "crc32"), key + ".crc32", 0, UINT32_MAX));
        const uint64_t bytes = uint64_t(c.integer(c.at(f, key, "bytes"), key + ".bytes", 0, INT64_MAX));
        const std::string file = (dir / name).string();
        if (!std::filesystem::exists(file)) {
            fail<IoError>("merge: chunk ", i, "/", count, " (", file, ") of manifest '", path,
                          "' is missing: rerun the bake with the same --chunk-dir to recompute it");
        }
        const auto [fileCrc, size] = fileChecksum(file);
        if (fileCrc != crc || size != bytes) {
            fail<IoError>("merge: chunk ", i, "/", count, " (", file, ") does not match its checksum "
                          "in manifest '", path, "' (damaged or half written): rerun the bake with "
                          "the same --chunk-dir to recompute it");
        }
        out[size_t(i)] = file;
    }
    return out; // count entries, each index once in [0, count): every chunk is there
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
