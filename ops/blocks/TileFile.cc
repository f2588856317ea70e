// Block tiles: the tile file (JSON "rockvdb-tile", version 1).
#include <rockvdb/core/Json.h>
#include <rockvdb/blocks/BlockTile.h>

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
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

std::array<float, 3> f3From(const json& j)
{
    if (!j.is_array() || j.size() != 3) fail<ValueError>("tile file: expected [x, y, z]");
    return {j[0].get<float>(), j[1].get<float>(), j[2].get<float>()};
}

} // namespace

BlockTile tileFromJson(const json& j)
{
    try {
        if (!j.is_object() || j.value("format", "") != "rockvdb-tile") {
            fail<ValueError>("tile file: not a rockvdb tile (format must be \"rockvdb-tile\")");
        }
        if (j.value("version", 0) != 1) {
            fail<ValueError>("tile file: unsupported version ", j.value("version", 0), " (expected 1)");
        }
        BlockTile t;
        t.params = BlockTileParams::fromJson(j.at("params"));
        t.params.resolveDefaults();
        t.params.validate();
        for (const auto& d : j.at("discs")) {
            if (!d.is_array() || d.size() != 7) fail<ValueError>("tile file: bad disc entry");
            t.discs.push_back({Vec3d(d[0].get<double>(), d[1].get<double>(), d[2].get<double>()),
                               Vec3d(d[3].get<double>(), d[4].get<double>(), d[5].get<double>()),
                               d[6].get<double>()});
        }
        for (const auto& jb : j.at("blocks")) {
            Block b;
            const std::string kind = jb.at("kind");
            if (kind == "polytope") {
                b.kind = BlockKind::Polytope;
                for (const auto& q : jb.at("planes")) {
                    if (!q.is_array() || q.size() != 4) fail<ValueError>("tile file: bad plane");
                    b.planes.push_back({q[0].get<float>(), q[1].get<float>(), q[2].get<float>(),
                                        q[3].get<float>()});
                }
                if (b.planes.empty()) fail<ValueError>("tile file: a polytope block has no planes");
            } else if (kind == "segment" || kind == "point") {
                b.kind = kind == "segment" ? BlockKind::Segment : BlockKind::Point;
                b.a = f3From(jb.at("a"));
                b.b = f3From(jb.at("b"));
                b.radius = jb.at("radius").get<float>();
                if (!(b.radius > 0)) fail<ValueError>("tile file: block radius must be > 0");
            } else if (kind == "expression") {
                b.kind = BlockKind::Expression;
                const json& e = jb.at("expression");
                if (!e.is_object()) fail<ValueError>("tile file: an expression block's expression is not an object");
                b.expression = e.dump();
                // Checked as the authored block it came from (bounded, slope 1, no terrain).
                (void)authoredExpressionField(b.expression, "tile file: expression block " +
                                                               std::to_string(t.blocks.size()));
                b.origin = f3From(jb.at("origin"));
            } else {
                fail<ValueError>("tile file: unknown block kind '", kind, "'");
            }
            for (const auto& v : jb.at("anchors")) b.anchors.push_back(f3From(v));
            if (b.anchors.empty()) fail<ValueError>("tile file: a block has no anchors");
            b.boundsMin = f3From(jb.at("bounds").at(0));
            b.boundsMax = f3From(jb.at("bounds").at(1));
            b.points = jb.value("points", 0);
            b.authored = jb.value("authored", false);
            t.blocks.push_back(std::move(b));
        }
        if (j.contains("stats")) {
            const json& s = j["stats"];
            t.stats.points = s.value("points", size_t(0));
            t.stats.discs = s.value("discs", size_t(0));
            t.stats.blocks = s.value("blocks", size_t(0));
            t.stats.meanPoints = s.value("mean_points", 0.0);
        }
        return t;
    } catch (const json::exception& e) {
        fail<ValueError>("tile file: malformed (", e.what(), ")");
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
            fail<ValueError>("tile file: '", path, "' is a .vdb without rockvdb:tile metadata "
                             "(write it with vdb_blocks)");
        }
        j = parseJsonOrDiscarded(text);
    } else {
        j = parseJsonOrDiscarded(bytes);
    }
    if (j.is_discarded()) {
        fail<ValueError>("tile file: '", path, "' is not JSON (expected a rockvdb tile)");
    }
    return tileFromJson(j);
}
} // namespace blocks
} // namespace rockvdb
