// SPDX-License-Identifier: Apache-2.0
// Block tiles: the tile file (JSON "rockvdb-tile", version 1).
#include <rockvdb/core/Json.h>
#include <rockvdb/blocks/BlockTile.h>

#include <rockvdb/core/Corrupt.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace rockvdb {
namespace blocks {

using nlohmann::json;

namespace {

std::array<double, 3> arr(const Vec3d& v) { return {v[0], v[1], v[2]}; }

// The double nearest the shortest decimal that reads back as the same float: the file
// prints ~9 digits per number instead of 17 and round-trips bit-exactly.
double shortFloat(float v)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g", double(v));
    return std::strtod(buf, nullptr);
}

json floats(const std::array<float, 3>& v)
{
    return {shortFloat(v[0]), shortFloat(v[1]), shortFloat(v[2])};
}

} // namespace

json tileToJson(const BlockTile& t)
{
    json j;
    j["format"] = "rockvdb-tile";
    j["version"] = 1;
    j["generator"] = std::string("rockvdb ") + version();
    j["params"] = t.params.toJson();
    json discs = json::array();
    for (const auto& d : t.discs) {
        discs.push_back({arr(d.center)[0], arr(d.center)[1], arr(d.center)[2], d.normal[0],
                         d.normal[1], d.normal[2], d.radius});
    }
    j["discs"] = discs;
    json blocks = json::array();
    for (const auto& b : t.blocks) {
        json jb;
        jb["kind"] = b.kind == BlockKind::Polytope ? "polytope"
                   : b.kind == BlockKind::Segment  ? "segment"
                   : b.kind == BlockKind::Expression ? "expression" : "point";
        if (b.kind == BlockKind::Expression) {
            jb["expression"] = json::parse(b.expression);
            jb["origin"] = floats(b.origin);
        } else if (b.kind == BlockKind::Polytope) {
            json planes = json::array();
            for (const auto& q : b.planes) {
                planes.push_back({shortFloat(q[0]), shortFloat(q[1]), shortFloat(q[2]),
                                  shortFloat(q[3])});
            }
            jb["planes"] = planes;
        } else {
            jb["a"] = floats(b.a);
            jb["b"] = floats(b.b);
            jb["radius"] = shortFloat(b.radius);
        }
        json anchors = json::array();
        for (const auto& a : b.anchors) anchors.push_back(floats(a));
        jb["anchors"] = anchors;
        jb["bounds"] = {floats(b.boundsMin), floats(b.boundsMax)};
        jb["points"] = b.points;
        if (b.authored) jb["authored"] = true;
        blocks.push_back(std::move(jb));
    }
    j["blocks"] = blocks;
    j["stats"] = t.stats.toJson();
    return j;
}

namespace {

// Limits a tile file's values must keep (issue 40: checked before anything is sized from
// them). Measured on 20 m tiles of every type, fill and hull-only: blocks span -0.55 s to
// 1.52 s, at most 1.07 s across, |d| <= 1.83 s, 176 planes and 16 anchors.
constexpr double kBoundsLow = -1.0, kBoundsHigh = 2.0; // block bounds, in tile sizes
constexpr double kMaxExtent = 1.5;                     // a block across, in tile sizes
constexpr size_t kMaxAnchors = 64, kMaxItems = 1u << 20;

std::array<float, 3> f3From(const Corrupt& c, const json& j, const std::string& key, double lo,
                            double hi)
{
    c.array(j, key, 3, 3);
    std::array<float, 3> v;
    for (size_t a = 0; a < 3; ++a) v[a] = float(c.number(j[a], Corrupt::item(key, a), lo, hi));
    return v;
}

Block blockFrom(const Corrupt& c, const json& jb, const std::string& key, double s, size_t index)
{
    Block b;
    const std::string kind = c.string(c.at(jb, key, "kind"), key + ".kind");
    const double lo = kBoundsLow * s, hi = kBoundsHigh * s;
    b.boundsMin = f3From(c, c.array(c.at(jb, key, "bounds"), key + ".bounds", 2, 2)[0], key + ".bounds[0]", lo, hi);
    b.boundsMax = f3From(c, jb["bounds"][1], key + ".bounds[1]", lo, hi);
    for (size_t a = 0; a < 3; ++a) {
        const double e = double(b.boundsMax[a]) - double(b.boundsMin[a]);
        if (!(e >= 0 && e <= kMaxExtent * s)) {
            c.fail(key + ".bounds", "spans " + std::to_string(e) + " m along axis " + std::to_string(a) +
                                        " (expected 0 to " + std::to_string(kMaxExtent * s) + ")");
        }
    }
    // Points of the block lie in its bounds (a little slack for float rounding).
    const double slack = 1e-3 * s;
    auto inBounds = [&](const json& j, const std::string& k) {
        std::array<float, 3> v;
        c.array(j, k, 3, 3);
        for (size_t a = 0; a < 3; ++a) {
            v[a] = float(c.number(j[a], Corrupt::item(k, a), double(b.boundsMin[a]) - slack,
                                  double(b.boundsMax[a]) + slack));
        }
        return v;
    };
    if (kind == "polytope") {
        b.kind = BlockKind::Polytope;
        const json& planes = c.array(c.at(jb, key, "planes"), key + ".planes", 1, kMaxPolytopePlanes);
        for (size_t k = 0; k < planes.size(); ++k) {
            const std::string pk = Corrupt::item(key + ".planes", k);
            c.array(planes[k], pk, 4, 4);
            std::array<float, 4> q;
            for (size_t m = 0; m < 3; ++m) q[m] = float(c.number(planes[k][m], Corrupt::item(pk, m), -1.0001, 1.0001));
            q[3] = float(c.number(planes[k][3], Corrupt::item(pk, 3), -4 * s, 4 * s));
            const double len = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2]);
            if (std::abs(len - 1.0) > 1e-4) {
                c.fail(pk, "has a normal of length " + std::to_string(len) + " (expected 1)");
            }
            b.planes.push_back(q);
        }
    } else if (kind == "segment" || kind == "point") {
        b.kind = kind == "segment" ? BlockKind::Segment : BlockKind::Point;
        b.a = inBounds(c.at(jb, key, "a"), key + ".a");
        b.b = inBounds(c.at(jb, key, "b"), key + ".b");
        b.radius = float(c.number(c.at(jb, key, "radius"), key + ".radius", 1e-9, s));
    } else if (kind == "expression") {
        b.kind = BlockKind::Expression;
        const json& e = c.at(jb, key, "expression");
        if (!e.is_object()) c.fail(key + ".expression", "is not an expression node");
        b.expression = e.dump();
        try {
            // Checked as the authored block it came from (bounded, slope 1, no terrain).
            (void)authoredExpressionField(b.expression, "expression block " + std::to_string(index));
        } catch (const ValueError& err) {
            c.fail(key + ".expression", std::string("is not a block: ") + err.what());
        }
        b.origin = f3From(c, c.at(jb, key, "origin"), key + ".origin", -2 * s, 2 * s);
    } else {
        c.fail(key + ".kind", "is '" + kind.substr(0, 40) + "' (expected polytope, segment, point or expression)");
    }
    const json& anchors = c.array(c.at(jb, key, "anchors"), key + ".anchors", 1, kMaxAnchors);
    for (size_t k = 0; k < anchors.size(); ++k) {
        b.anchors.push_back(inBounds(anchors[k], Corrupt::item(key + ".anchors", k)));
    }
    // The first anchor (the centroid) is in the home tile [0, s)³.
    for (size_t a = 0; a < 3; ++a) {
        const double v = b.anchors[0][a];
        if (!(v >= -slack && v <= s + slack)) {
            c.fail(Corrupt::item(key + ".anchors[0]", a), "has value " + std::to_string(v) +
                                                              " (expected 0 to the tile size, " + std::to_string(s) + ")");
        }
    }
    if (jb.contains("points")) b.points = int(c.integer(jb["points"], key + ".points", 0, int64_t(kMaxItems) * 64));
    if (jb.contains("authored")) {
        if (!jb["authored"].is_boolean()) c.fail(key + ".authored", "is not true or false");
        b.authored = jb["authored"].get<bool>();
    }
    return b;
}

} // namespace

BlockTile tileFromJson(const json& j, const std::string& what, const std::string& root)
{
    const Corrupt c(what, root);
    try {
        if (!j.is_object() || !j.contains("format") || j["format"] != "rockvdb-tile") {
            fail<IoError>(what, ": not a rockvdb tile (format must be \"rockvdb-tile\")");
        }
        const int64_t version = c.integer(c.at(j, "", "version"), "version", 0, INT32_MAX);
        if (version != 1) fail<IoError>(what, ": unsupported version ", version, " (expected 1)");
        BlockTile t;
        try {
            t.params = BlockTileParams::fromJson(c.at(j, "", "params"));
            t.params.resolveDefaults();
            t.params.validate();
        } catch (const ValueError& e) {
            c.fail("params", std::string("are not a tile's: ") + e.what());
        }
        const double s = t.params.tileSize;
        const json& discs = c.array(c.at(j, "", "discs"), "discs", 0, kMaxItems);
        for (size_t i = 0; i < discs.size(); ++i) {
            const std::string k = Corrupt::item("discs", i);
            const json& d = c.array(discs[i], k, 7, 7);
            double v[7];
            for (size_t m = 0; m < 7; ++m) {
                const double lim = m < 3 ? 1e3 * s : m < 6 ? 1.0001 : 4 * s;
                v[m] = c.number(d[m], Corrupt::item(k, m), m == 6 ? 1e-9 : -lim, lim);
            }
            const Vec3d n(v[3], v[4], v[5]);
            if (std::abs(n.length() - 1.0) > 1e-4) c.fail(k, "has a normal of length " + std::to_string(n.length()) + " (expected 1)");
            t.discs.push_back({Vec3d(v[0], v[1], v[2]), n, v[6]});
        }
        const json& blocks = c.array(c.at(j, "", "blocks"), "blocks", 0, kMaxItems);
        for (size_t i = 0; i < blocks.size(); ++i) {
            t.blocks.push_back(blockFrom(c, blocks[i], Corrupt::item("blocks", i), s, i));
        }
        if (j.contains("stats")) {
            const json& st = j["stats"];
            auto count = [&](const char* name) {
                return st.contains(name) ? size_t(c.integer(st[name], std::string("stats.") + name, 0, int64_t(1) << 40)) : size_t(0);
            };
            t.stats.points = count("points");
            t.stats.discs = count("discs");
            t.stats.blocks = count("blocks");
            t.stats.meanPoints = st.contains("mean_points") ? c.number(st["mean_points"], "stats.mean_points", 0, 1e12) : 0.0;
        }
        return t;
    } catch (const json::exception& e) {
        fail<IoError>("corrupt ", what, ": malformed (", e.what(), ")");
    }
}

void writeTile(const BlockTile& tile, const std::string& path)
{
    writeFileAtomic(path, jsonText(tileToJson(tile)) + "\n");
}

BlockTile readTile(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in) fail<IoError>("tile file: cannot open '", path, "'");
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string bytes = ss.str();
    json j;
    // A vdb_blocks .vdb carries the tile as metadata "rockvdb:tile" on grid "surface".
    if (bytes.size() >= 4 && bytes.compare(0, 4, std::string(" BDV", 4)) == 0) {
        std::string text;
        try {
            openvdb::io::File file(path);
            file.open(false);
            const openvdb::GridPtrVecPtr grids = file.readAllGridMetadata();
            file.close();
            for (const auto& g : *grids) {
                if (auto m = g->getMetadata<openvdb::StringMetadata>("rockvdb:tile")) {
                    text = m->value();
                    break;
                }
            }
        } catch (const openvdb::Exception& e) {
            fail<IoError>("tile file: cannot read '", path, "' (", e.what(), ")");
        }
        if (text.empty()) {
            fail<IoError>("tile file: '", path, "' is a .vdb without rockvdb:tile metadata "
                          "(write it with vdb_blocks)");
        }
        j = parseJsonOrDiscarded(text);
        if (j.is_discarded()) fail<IoError>("corrupt tile file '", path, "': rockvdb:tile is not JSON");
        return tileFromJson(j, "tile file '" + path + "'", "rockvdb:tile");
    }
    j = parseJsonOrDiscarded(bytes);
    if (j.is_discarded()) {
        fail<IoError>("tile file: '", path, "' is not JSON (expected a rockvdb tile)");
    }
    return tileFromJson(j, "tile file '" + path + "'", "");
}
} // namespace blocks
} // namespace rockvdb
