// SPDX-License-Identifier: Apache-2.0
// Block tiles: the parameters' derived defaults and rules, user fractures and authored blocks from JSON.
#include <rockvdb/blocks/TileBuild.h>
#include <rockvdb/blocks/BlocksStage.h>

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/core/Primitives.h>

#include <nlohmann/json.hpp>
#include <openvdb/math/Mat3.h>

#include <cmath>
#include <string>

namespace rockvdb {
namespace blocks {

using nlohmann::json;

using namespace tilegen;

namespace {

const char* kTypeNames[] = {"equidimensional", "prismatic", "polyhedral",
                            "rhombohedral",    "tabular",   "columnar"};

} // namespace

BlockType blockTypeFromString(const std::string& name)
{
    for (int t = 0; t < 6; ++t) {
        if (name == kTypeNames[t]) return BlockType(t);
    }
    fail<ValueError>("blocks: unknown type '", name,
                     "' (expected equidimensional, prismatic, polyhedral, rhombohedral, "
                     "tabular or columnar)");
}

const char* blockTypeName(BlockType type) { return kTypeNames[int(type)]; }

// The derived defaults (rules of the table, tileSchema(); here their numbers), scaled by the
// tile size s (the paper uses s ≈ 20 m; Table 1 for the counts):
//   points: Poisson radius 0.034·s ≈ 0.68 m → ≈ 14 600 points (Table 1: 14 524–14 589; the
//           paper's "r ≈ 10 cm" cannot give that count in a 20 m cube); edges up to 2r.
//   Set-based types place each set's discs evenly spaced along its normal (§3).
//   equidimensional 15 discs (5 per set), radii 0.5–0.7·s, jitter 1°, 10% irregular. The
//           paper's ≈ 5 m radii leave most fractures partial: the visibility splits then
//           extend them by whole planes and leave thin slivers (measured median min/max
//           extent 0.35); near-full discs give the near-cubic blocks the type is named for
//           (0.55). Jitter stays small: a large disc tilted by θ meets its periodic images
//           s·tan θ apart, and the gap between the two sheets becomes a sliver block;
//   prismatic 18 discs, radii 0.2–0.3·s, jitter 8°, 25% irregular ("slightly more
//           irregular");
//   polyhedral 44 discs, centres 0.05·s apart (the paper's ≈ 1 m spacing of disc centres; it
//           gives no radii), radii 0.05–0.15·s, random normals;
//   rhombohedral 24 discs, radii 0.12–0.22·s, jitter 2°, three sets at 60° to each other;
//   tabular 30 discs: a third bedding planes (radius s), the rest radius 0.08–0.12·s (≈ s/10);
//   columnar 18 discs: radii 0.5–0.7·s along three sets 60° apart, 15% cross-joints.
//   smooth-radius R 0.0125·s and warp-amplitude 0.0025·s (0.25 m and 0.05 m at 20 m): the
//           rounding and the warp eat rock in proportion to their size over the blocks',
//           so a tile scaled down keeps its share of rock (seed 3, voxel s/50: 89–91 % at
//           5, 10, 20 and 40 m; with 0.25 / 0.05 m absolute, 63–76 % at 5 m).
const TypeDefaults& tilegen::typeDefaults(BlockType type)
{
    static const TypeDefaults defaults[6] = {
        {15, 0.10, 0.50, 0.70, 1, 0.10},  // equidimensional
        {18, 0.10, 0.20, 0.30, 8, 0.25},  // prismatic
        {44, 0.05, 0.05, 0.15, 0, 1.00},  // polyhedral
        {24, 0.10, 0.12, 0.22, 2, 0.10},  // rhombohedral
        {30, 0.10, 0.08, 0.12, 5, 0.00},  // tabular (small discs; beds have radius s)
        {18, 0.08, 0.50, 0.70, 3, 0.15},  // columnar
    };
    return defaults[int(type)];
}

void BlockTileParams::resolveDefaults() { *this = tileSchema().derive(*this); }

void BlockTileParams::validate() const { tileSchema().validate(*this); }

// The rules between the tile's rows (the table checks each row's own range), on derived
// values; names are the table's.
void tilegen::checkTileRules(const BlockTileParams& p)
{
    const char* op = "blocks";
    const double tileSize = p.tileSize;
    require(p.pointRadius > 0 && p.pointRadius < tileSize / 2, op, "point-radius",
            "in (0, tile-size / 2)", p.pointRadius);
    require(tileSize / p.pointRadius <= 400, op, "tile-size / point-radius", "<= 400",
            tileSize / p.pointRadius);
    require(p.neighbourRadius > p.pointRadius && p.neighbourRadius < tileSize / 2, op,
            "neighbour-radius", "in (point-radius, tile-size / 2)", p.neighbourRadius);
    require(p.discSpacing >= 0 && p.discSpacing < tileSize / 2, op, "disc-spacing",
            "in [0, tile-size / 2)", p.discSpacing);
    require(p.discRadiusMin > 0, op, "disc-radius (min)", "> 0", p.discRadiusMin);
    require(p.discRadiusMax >= p.discRadiusMin && p.discRadiusMax <= 4 * tileSize, op,
            "disc-radius (max)", "in [min, 4 x tile-size]", p.discRadiusMax);
    require(p.axis.length() > 1e-9, op, "axis", "a non-zero vector",
            std::to_string(p.axis[0]) + "," + std::to_string(p.axis[1]) + "," + std::to_string(p.axis[2]));
    require(p.fractureWidth >= 0 && p.fractureWidth < p.pointRadius, op, "fracture-width",
            "in [0, point-radius) m", p.fractureWidth);
    require(p.smoothRadius >= 0 && p.smoothRadius < tileSize / 4, op, "smooth-radius",
            "in [0, tile-size / 4)", p.smoothRadius);
    require(p.relief.amplitude >= 0 && p.relief.amplitude <= tileSize / 20, op, "warp-amplitude",
            "in [0, tile-size / 20]", p.relief.amplitude);
    const auto& extraDiscs = p.extraDiscs;
    const auto& authored = p.authored;
    for (size_t i = 0; i < extraDiscs.size(); ++i) {
        const Disc& d = extraDiscs[i];
        const std::string what = "fracture " + std::to_string(i);
        require(finite3(d.center), op, (what + " centre").c_str(), "finite", "non-finite");
        require(finite3(d.normal) && d.normal.length() > 1e-9, op, (what + " normal").c_str(),
                "a non-zero vector", "zero");
        require(std::isfinite(d.radius) && d.radius > 0 && d.radius <= 4 * tileSize, op,
                (what + " radius").c_str(), "in (0, 4 · tile size]", d.radius);
    }
    for (size_t i = 0; i < authored.size(); ++i) {
        const std::string what = "authored block " + std::to_string(i);
        if (authored[i].isExpression()) {
            const FieldPtr f = authored[i].field ? authored[i].field
                                                 : authoredExpressionField(authored[i].expression, what);
            const BBoxd bb = f->bounds();
            const Vec3d ext = bb.extents();
            const double extent = std::max({ext[0], ext[1], ext[2]});
            if (extent > tileSize) {
                fail<ValueError>(op, ": ", what, " is ", extent, " m across, wider than the ", tileSize,
                                 " m tile (a periodic tile cannot hold a block wider than itself); "
                                 "make it smaller or raise --tile-size");
            }
            continue;
        }
        require(authored[i].planes.size() >= 4, op, what.c_str(), "at least 4 planes",
                authored[i].planes.size());
        for (const auto& q : authored[i].planes) {
            require(std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]) &&
                        std::isfinite(q[3]) && std::hypot(q[0], q[1], q[2]) > 1e-9,
                    op, (what + " plane").c_str(), "finite with a non-zero normal", "bad plane");
        }
        // A block wider than the tile overlaps its own periodic images (and one 1e6 m wide
        // would be voxelised over its whole extent): each must be bounded and fit the tile.
        require(authored[i].planes.size() <= kMaxPolytopePlanes, op, what.c_str(),
                "at most 512 planes", authored[i].planes.size());
        std::vector<Plane> planes;
        for (const auto& q : authored[i].planes) planes.push_back({Vec3d(q[0], q[1], q[2]), q[3]});
        const std::vector<Vec3d> verts = polytopeVertices(planes);
        if (verts.empty()) {
            fail<ValueError>(op, ": ", what, " is empty or unbounded (its planes enclose no finite volume)");
        }
        Vec3d lo = verts[0], hi = verts[0];
        for (const auto& v : verts) {
            lo = minComponent(lo, v);
            hi = maxComponent(hi, v);
        }
        const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
        if (extent > tileSize) {
            fail<ValueError>(op, ": ", what, " is ", extent, " m across, wider than the ", tileSize,
                             " m tile (a periodic tile cannot hold a block wider than itself); "
                             "make it smaller or raise --tile-size");
        }
    }
}

namespace {

Vec3d vecFrom(const json& j, const std::string& key)
{
    if (!j.is_array() || j.size() != 3) {
        fail<ValueError>("blocks: ", key, " must be an array of 3 numbers");
    }
    Vec3d v;
    for (int a = 0; a < 3; ++a) {
        if (!j[size_t(a)].is_number()) fail<ValueError>("blocks: ", key, " must hold numbers");
        v[a] = j[size_t(a)].get<double>();
    }
    return v;
}

double numFrom(const json& j, const std::string& key)
{
    if (!j.is_number()) fail<ValueError>("blocks: ", key, " must be a number");
    return j.get<double>();
}

void allowKeys(const json& j, const std::string& where, std::initializer_list<const char*> keys)
{
    if (!j.is_object()) fail<ValueError>("blocks: ", where, " must be an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
        bool ok = false;
        for (const char* k : keys) ok = ok || it.key() == k;
        if (!ok) fail<ValueError>("blocks: unknown key '", it.key(), "' in ", where);
    }
}

} // namespace

std::vector<Disc> fracturesFromJson(const json& j)
{
    if (!j.is_array()) fail<ValueError>("blocks: fractures must be an array of discs");
    std::vector<Disc> out;
    for (size_t i = 0; i < j.size(); ++i) {
        const std::string w = "fractures[" + std::to_string(i) + "]";
        allowKeys(j[i], w, {"center", "normal", "radius"});
        for (const char* k : {"center", "normal", "radius"}) {
            if (!j[i].contains(k)) fail<ValueError>("blocks: ", w, " needs \"", k, "\"");
        }
        out.push_back({vecFrom(j[i]["center"], w + ".center"), vecFrom(j[i]["normal"], w + ".normal"),
                       numFrom(j[i]["radius"], w + ".radius")});
    }
    return out;
}

namespace {

// Expression nodes a block cannot be: terrains (unbounded sheets, file paths a tile file
// could not carry) and warps (not a distance bound; the tile's warp-* rows roughen blocks).
void refuseNodes(const json& j, const std::string& w)
{
    if (j.is_array()) {
        for (size_t k = 0; k < j.size(); ++k) refuseNodes(j[k], w);
        return;
    }
    if (!j.is_object()) return;
    if (j.contains("type") && j["type"].is_string()) {
        const std::string t = j["type"];
        if (t == "heightfield" || t == "noise_terrain" || t == "sea_cliff") {
            fail<ValueError>("blocks: ", w, " holds a '", t, "' node: a block is a bounded solid, "
                             "not a terrain (amplify a terrain with vdb_amplify instead)");
        }
        if (t == "warp") {
            fail<ValueError>("blocks: ", w, " holds a 'warp' node: a block's expression must be "
                             "a distance bound; the tile's warp-* parameters roughen every block");
        }
    }
    for (const auto& [key, value] : j.items()) {
        if (key == "child" || key == "children") refuseNodes(value, w);
    }
}

} // namespace

FieldPtr authoredExpressionField(const std::string& text, const std::string& what)
{
    const json j = parseJsonOrDiscarded(text);
    if (j.is_discarded()) fail<ValueError>("blocks: ", what, " is not JSON");
    refuseNodes(j, what);
    FieldPtr f;
    try {
        f = fieldFromJson(j, ExpressionContext{});
    } catch (const ValueError& e) {
        fail<ValueError>("blocks: ", what, ": ", e.what());
    }
    if (!isBounded(f->bounds()) || f->bounds().empty()) {
        fail<ValueError>("blocks: ", what, " is unbounded (a plane or a difference from "
                         "nothing); intersect it with a bounded shape");
    }
    // The tile field's culling takes each block's base for a 1-Lipschitz distance bound.
    if (f->lipschitz() > 1.0 + 1e-9 || f->modulus(1.0) > 1.0 + 1e-9) {
        fail<ValueError>("blocks: ", what, " is not a distance bound of slope 1 (slope ",
                         std::max(f->lipschitz(), f->modulus(1.0)), ")");
    }
    return f;
}

namespace {

AuthoredBlock expressionBlock(const json& node, const std::string& w)
{
    AuthoredBlock a;
    a.expression = node.dump();
    a.field = authoredExpressionField(a.expression, w);
    return a;
}

AuthoredBlock authoredFromJson(const json& j, const std::string& w)
{
    if (!j.is_object() || !j.contains("type") || !j["type"].is_string()) {
        fail<ValueError>("blocks: ", w, " needs a \"type\" (box, polytope or an expression node)");
    }
    AuthoredBlock a;
    const std::string type = j["type"];
    if (type == "expression") {
        allowKeys(j, w, {"type", "expression"});
        if (!j.contains("expression") || !j["expression"].is_object()) {
            fail<ValueError>("blocks: ", w, " needs \"expression\": {an expression node}");
        }
        return expressionBlock(j["expression"], w);
    }
    if (type == "box") {
        allowKeys(j, w, {"type", "center", "size", "rotate"});
        if (!j.contains("size")) fail<ValueError>("blocks: ", w, " needs \"size\"");
        const Vec3d c = j.contains("center") ? vecFrom(j["center"], w + ".center") : Vec3d(0);
        const Vec3d size = vecFrom(j["size"], w + ".size");
        for (int k = 0; k < 3; ++k) {
            if (!(size[k] > 0)) fail<ValueError>("blocks: ", w, ".size must be positive");
        }
        const Vec3d rot = j.contains("rotate") ? vecFrom(j["rotate"], w + ".rotate") : Vec3d(0);
        openvdb::math::Mat3d R = openvdb::math::rotation<openvdb::math::Mat3d>(
                                     openvdb::math::X_AXIS, rot[0] * M_PI / 180) *
                                 openvdb::math::rotation<openvdb::math::Mat3d>(
                                     openvdb::math::Y_AXIS, rot[1] * M_PI / 180) *
                                 openvdb::math::rotation<openvdb::math::Mat3d>(
                                     openvdb::math::Z_AXIS, rot[2] * M_PI / 180);
        for (int axisIdx = 0; axisIdx < 3; ++axisIdx) {
            for (double sgn : {1.0, -1.0}) {
                Vec3d e(0);
                e[axisIdx] = sgn;
                const Vec3d n = R.transform(e);
                a.planes.push_back({n[0], n[1], n[2], n.dot(c) + 0.5 * size[axisIdx]});
            }
        }
    } else if (type == "polytope") {
        allowKeys(j, w, {"type", "planes"});
        if (!j.contains("planes") || !j["planes"].is_array()) {
            fail<ValueError>("blocks: ", w, " needs \"planes\": [[nx, ny, nz, d], ...]");
        }
        for (const auto& q : j["planes"]) {
            if (!q.is_array() || q.size() != 4) {
                fail<ValueError>("blocks: ", w, ".planes entries must be [nx, ny, nz, d]");
            }
            std::array<double, 4> pl;
            for (size_t k = 0; k < 4; ++k) pl[k] = numFrom(q[k], w + ".planes");
            a.planes.push_back(pl);
        }
    } else {
        // Any other node of the expression language (its parser names unknown types).
        return expressionBlock(j, w);
    }
    return a;
}

} // namespace

std::vector<AuthoredBlock> authoredListFromJson(const json& j)
{
    if (!j.is_array()) fail<ValueError>("blocks: authored must be an array");
    std::vector<AuthoredBlock> out;
    for (size_t i = 0; i < j.size(); ++i) {
        out.push_back(authoredFromJson(j[i], "authored[" + std::to_string(i) + "]"));
    }
    return out;
}

json BlockTileStats::toJson() const
{
    return {{"points", points},           {"edges", edges},
            {"cut_edges", cutEdges},      {"discs", discs},
            {"blocks", blocks},           {"dropped_clusters", droppedClusters},
            {"dropped_points", droppedPoints}, {"visibility_splits", visibilitySplits},
            {"wrap_cuts", wrapCuts},      {"merged_clusters", mergedClusters},
            {"small_blocks", smallBlocks},
            {"mean_points", meanPoints}};
    // No timings: a tile file (and the rockvdb:tile metadata) is a pure function of the
    // parameters, so the same call writes the same bits; times go to stderr and bench/.
}
} // namespace blocks
} // namespace rockvdb
