// Rock tiles as grids: each rock's level set (from its density ρ), the library of every rock's
// level set in its own slot, and the tile set file (the ρ atlas with its description).
#include <rockvdb/core/Json.h>
#include <rockvdb/rockpile/RockTiles.h>

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/GridUtil.h>

#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace rockvdb {
namespace rockpile {

using openvdb::Coord;

// ---- level sets ---------------------------------------------------------------------------

namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;

// Scratch arrays reused by each thread's rocks (a rock's box is ~10⁴ voxels; allocating
// them per rock cost more than filling them).
struct LevelSetScratch
{
    std::vector<float> r, d2;
    std::vector<Vec3f> cp;
    std::vector<uint8_t> done;
    std::vector<int32_t> front, next;
};

// The leaves of a rock's level set (see rockLevelSet), inactive voxels at ±background by
// side: ready to be added to any tree. Every inside voxel lies in a leaf, so a tree made of
// such leaves needs no sign flood fill.
std::vector<LeafT*> rockLeaves(const Rock& rock, double voxelSize, const Coord& offset,
                               double halfWidth)
{
    std::vector<LeafT*> out;
    if (rock.rho.empty()) return out;
    thread_local LevelSetScratch scratch;
    LevelSetScratch& sc = scratch;
    const float bg = float(halfWidth * voxelSize);
    // The trilinear surface r = 2ρ − 1 = 0 is sampled where it crosses the grid's edges, and
    // each voxel's nearest crossing is carried outward layer by layer over the band (each
    // layer offers its crossings to its 26 neighbours; a voxel keeps the nearest offered):
    // distances to the sampled surface. Dense arrays over the rock's box padded by the band;
    // cp holds the vector from a voxel to its crossing, d2 its squared length.
    const int pad = int(std::ceil(halfWidth)) + 1;
    const int nx = rock.dims[0] + 2 * pad, ny = rock.dims[1] + 2 * pad, nz = rock.dims[2] + 2 * pad;
    const size_t total = size_t(nx) * ny * nz;
    const int sx = ny * nz, sy = nz;
    constexpr float kFar = std::numeric_limits<float>::max();
    sc.r.assign(total, -0.5f);
    sc.d2.assign(total, kFar);
    sc.cp.resize(total);
    sc.done.assign(total, 0);
    // Raw pointers: stores through uint8_t may alias anything, so through the vectors every
    // store to done would reload every array's address.
    float* const r = sc.r.data();
    float* const d2 = sc.d2.data();
    Vec3f* const cp = sc.cp.data();
    uint8_t* const done = sc.done.data();
    for (int x = 0; x < rock.dims[0]; ++x)
        for (int y = 0; y < rock.dims[1]; ++y) {
            const float* src = rock.rho.data() + size_t((x * rock.dims[1] + y) * rock.dims[2]);
            float* dst = r + size_t((x + pad) * sx + (y + pad) * sy + pad);
            for (int z = 0; z < rock.dims[2]; ++z) dst[z] = src[z] - 0.5f;
        }
    std::vector<int32_t>& front = sc.front;
    std::vector<int32_t>& next = sc.next;
    front.clear();
    // Crossings lie within the rock's box grown by one voxel. Each is offered to the 18
    // voxels round its edge (the edge's ends and their 8 neighbours across it), which takes
    // the nearest crossing of every voxel near the surface exactly.
    const int stride[3] = {sx, sy, 1};
    for (int x = pad - 1; x < pad + rock.dims[0]; ++x)
        for (int y = pad - 1; y < pad + rock.dims[1]; ++y)
            for (int z = pad - 1; z < pad + rock.dims[2]; ++z) {
                const int i = x * sx + y * sy + z;
                const float rc = r[i];
                for (int a = 0; a < 3; ++a) {
                    const float rj = r[i + stride[a]];
                    if ((rc > 0) == (rj > 0)) continue;
                    const float t = rc / (rc - rj);
                    const int b = (a + 1) % 3, c = (a + 2) % 3;
                    for (int side = 0; side < 2; ++side)
                        for (int db = -1; db <= 1; ++db)
                            for (int dc = -1; dc <= 1; ++dc) {
                                const int k = i + side * stride[a] + db * stride[b] + dc * stride[c];
                                Vec3f v;
                                v[a] = side ? t - 1.0f : t;
                                v[b] = float(-db);
                                v[c] = float(-dc);
                                const float dd = v.lengthSqr();
                                if (dd < d2[k]) {
                                    d2[k] = dd;
                                    cp[k] = v;
                                }
                                if (!done[k]) {
                                    done[k] = 1;
                                    front.push_back(k);
                                }
                            }
                }
            }
    int nb[26];
    Vec3f nbOffset[26];
    {
        int q = 0;
        for (int i = -1; i <= 1; ++i)
            for (int j = -1; j <= 1; ++j)
                for (int k = -1; k <= 1; ++k) {
                    if (!(i || j || k)) continue;
                    nb[q] = i * sx + j * sy + k;
                    nbOffset[q++] = Vec3f(float(i), float(j), float(k));
                }
    }
    // Each layer pushes its crossings to the not yet finished neighbours; the next layer is
    // the set of voxels reached (in the order first reached: deterministic). The first
    // layer lies within a voxel of the crossings' edges, so pad − 2 more reach every voxel
    // nearer than the half width, and the padding keeps their neighbours inside the box.
    for (int layer = 0; layer < pad - 2 && !front.empty(); ++layer) {
        next.clear();
        for (const int c : front) {
            const Vec3f vc = cp[c];
            for (int q = 0; q < 26; ++q) {
                const int u = c + nb[q];
                const uint8_t state = done[u];
                const Vec3f v = vc - nbOffset[q];
                const float dd = v.lengthSqr();
                if (state == 0) {
                    done[u] = 2;
                    next.push_back(u);
                    d2[u] = dd;
                    cp[u] = v;
                } else if (dd < d2[u]) {
                    d2[u] = dd;
                    cp[u] = v;
                }
            }
        }
        for (const int u : next) done[u] = 1;
        front.swap(next);
    }
    // Straight into leaves: band voxels active, the rest ±background by side.
    const float band2 = float(halfWidth * halfWidth);
    const float scale = float(voxelSize);
    const Coord base = rock.origin.offsetBy(-pad, -pad, -pad) + offset;
    const Coord last = base.offsetBy(nx - 1, ny - 1, nz - 1);
    const Coord first = base & ~7;
    for (int lx = first[0]; lx <= last[0]; lx += 8)
        for (int ly = first[1]; ly <= last[1]; ly += 8)
            for (int lz = first[2]; lz <= last[2]; lz += 8) {
                LeafT* leaf = nullptr;
                float* values = nullptr;
                const int z0 = std::max(lz, base[2]), z1 = std::min(lz + 8, last[2] + 1);
                for (int x = std::max(lx, base[0]); x < std::min(lx + 8, last[0] + 1); ++x)
                    for (int y = std::max(ly, base[1]); y < std::min(ly + 8, last[1] + 1); ++y) {
                        const int row = (x - base[0]) * sx + (y - base[1]) * sy - base[2];
                        const openvdb::Index rowOffset = ((x & 7) << 6) | ((y & 7) << 3);
                        for (int z = z0; z < z1; ++z) {
                            const int i = row + z;
                            const bool in = r[i] > 0;
                            const bool band = d2[i] < band2;
                            if (!band && !in) continue;
                            if (!leaf) {
                                leaf = new LeafT(Coord(lx, ly, lz), bg);
                                values = leaf->buffer().data();
                            }
                            const openvdb::Index n = rowOffset | openvdb::Index(z & 7);
                            if (band) {
                                const float d = std::sqrt(d2[i]) * scale;
                                values[n] = in ? -d : d;
                                leaf->getValueMask().setOn(n);
                            } else {
                                values[n] = -bg;
                            }
                        }
                    }
                if (leaf) out.push_back(leaf);
            }
    return out;
}

} // namespace

std::vector<LeafT*> rockLeavesShifted(const Rock& rock, double voxelSize, const Coord& offset,
                                      double halfWidth)
{
    return rockLeaves(rock, voxelSize, offset, halfWidth);
}

openvdb::CoordBBox rockLeafBounds(const Rock& rock, const Coord& offset, double halfWidth)
{
    if (rock.rho.empty()) return openvdb::CoordBBox();
    // As rockLeaves: the rock's box padded by the band, shifted, out to whole leaves.
    const int pad = int(std::ceil(halfWidth)) + 1;
    const Coord base = rock.origin.offsetBy(-pad, -pad, -pad) + offset;
    const Coord last = base.offsetBy(rock.dims[0] + 2 * pad - 1, rock.dims[1] + 2 * pad - 1,
                                     rock.dims[2] + 2 * pad - 1);
    return openvdb::CoordBBox(base & ~7, (last & ~7).offsetBy(7));
}

openvdb::FloatGrid::Ptr rockLevelSet(const Rock& rock, double voxelSize, const Coord& offset,
                                     double halfWidth)
{
    auto grid = emptyLevelSet("surface", voxelSize, float(halfWidth * voxelSize));
    // (No flood fill: every inside voxel is in a leaf.)
    for (LeafT* leaf : rockLeaves(rock, voxelSize, offset, halfWidth)) grid->tree().addLeaf(leaf);
    return grid;
}

namespace {

// Atlas slots: 8-aligned boxes large enough for any rock's box (3 cells) padded by @a pad
// voxels, so no two rocks share a leaf. Rock i's canonical voxel v sits at v + offset_i.
std::vector<Coord> atlasOffsets(const TileSet& set, int pad)
{
    const int slot = ((3 * set.params.voxelsPerCell + 2 * pad + 2) + 7) / 8 * 8;
    const size_t count = set.rocks.size();
    const int side = std::max(1, int(std::ceil(std::cbrt(double(std::max<size_t>(count, 1))))));
    std::vector<Coord> offsets(count);
    for (size_t i = 0; i < count; ++i) {
        const Coord s(int(i % size_t(side)), int((i / size_t(side)) % size_t(side)),
                      int(i / size_t(side * side)));
        offsets[i] = scaled(s, slot) - set.rocks[i].origin.offsetBy(-pad, -pad, -pad);
    }
    return offsets;
}

constexpr int kRhoPad = 1;

} // namespace

openvdb::FloatGrid::Ptr libraryGrid(const TileSet& set, double halfWidth, double* seconds)
{
    Task task;
    return libraryGrid(set, task, halfWidth, seconds);
}

openvdb::FloatGrid::Ptr libraryGrid(const TileSet& set, Task& task, double halfWidth,
                                    double* seconds)
{
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    const double dx = set.params.voxelSize();
    const int pad = int(std::ceil(halfWidth)) + 1;
    const std::vector<Coord> offsets = atlasOffsets(set, pad);
    const size_t count = set.rocks.size();
    std::vector<std::vector<LeafT*>> leaves(count);
    try {
        parallelFor(task, count, 16, [&](size_t i) {
            leaves[i] = rockLeaves(set.rocks[i], dx, offsets[i], halfWidth);
        });
    } catch (...) {
        for (auto& list : leaves)
            for (LeafT* leaf : list) delete leaf;
        throw;
    }
    auto library = emptyLevelSet("library", dx, float(halfWidth * dx));
    for (auto& list : leaves)
        for (LeafT* leaf : list) library->tree().addLeaf(leaf);
    nlohmann::json slots = nlohmann::json::array();
    for (size_t i = 0; i < count; ++i) slots.push_back({offsets[i][0], offsets[i][1], offsets[i][2]});
    library->insertMeta("rockvdb:library_offsets", openvdb::StringMetadata(jsonText(slots)));
    if (seconds) *seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return library;
}

openvdb::FloatGrid::Ptr tileGrid(const TileSet& set)
{
    Task task;
    return tileGrid(set, task);
}

openvdb::FloatGrid::Ptr tileGrid(const TileSet& set, Task& task)
{
    const RockTileParams& p = set.params;
    const double dx = p.voxelSize();
    const std::vector<Coord> offsets = atlasOffsets(set, kRhoPad);
    auto rho = openvdb::FloatGrid::create(0.0f);
    rho->setTransform(openvdb::math::Transform::createLinearTransform(dx));
    rho->setGridClass(openvdb::GRID_FOG_VOLUME);
    rho->setName("rho");
    rho->setSaveFloatAsHalf(true);
    auto acc = rho->getAccessor();
    nlohmann::json rocks = nlohmann::json::array();
    for (size_t i = 0; i < set.rocks.size(); ++i) {
        if (i % 256 == 0) task.step(double(i) / double(set.rocks.size()));
        const Rock& r = set.rocks[i];
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    const float v = r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)];
                    if (v > 0) acc.setValue(r.origin.offsetBy(x, y, z) + offsets[i], v);
                }
        char key[17];
        std::snprintf(key, sizeof key, "%016llx", static_cast<unsigned long long>(r.seed.key));
        rocks.push_back({{"key", key},
                         {"seed", {r.seed.p[0], r.seed.p[1], r.seed.p[2]}},
                         {"offset", {offsets[i][0], offsets[i][1], offsets[i][2]}},
                         {"origin", {r.origin[0], r.origin[1], r.origin[2]}},
                         {"dims", {r.dims[0], r.dims[1], r.dims[2]}},
                         {"solid", r.solidVoxels()},
                         {"voronoi", r.voronoiVoxels},
                         {"contacts", r.contacts.size()}});
    }
    nlohmann::json regions = nlohmann::json::array();
    for (const Region& g : set.regions) {
        regions.push_back({{"type", g.type}, {"axes", g.axes}, {"colours", g.colours},
                           {"rocks", g.rocks}});
    }
    const RockTileStats& st = set.stats;
    nlohmann::json meta = {
        {"format", 1},
        {"params", p.toJson()},
        {"voxel_size", dx},
        {"stats", {{"stones", st.stones}, {"regions", st.regions}, {"seeds", st.seeds},
                   {"contacts", st.contacts}}},
        {"regions", regions},
        {"rocks", rocks}};
    rho->insertMeta("rockvdb:tiles", openvdb::StringMetadata(jsonText(meta)));
    return rho;
}

TileSet tilesFromGrid(const openvdb::FloatGrid& rho)
{
    const auto meta = rho.getMetadata<openvdb::StringMetadata>("rockvdb:tiles");
    if (!meta) fail<ValueError>("rockpile: grid '", rho.getName(), "' holds no tile set (no rockvdb:tiles metadata)");
    const nlohmann::json j = parseJsonOrDiscarded(meta->value());
    if (j.is_discarded() || !j.contains("format") || j["format"] != 1) {
        fail<ValueError>("rockpile: unreadable tile set description (format 1 expected)");
    }
    TileSet set;
    // Format 1 files written before the parameter tables spelt keys with '_'.
    nlohmann::json params = nlohmann::json::object();
    for (auto it = j.at("params").begin(); it != j.at("params").end(); ++it) {
        std::string key = it.key();
        std::replace(key.begin(), key.end(), '_', '-');
        params[key] = it.value();
    }
    set.params = RockTileParams::fromJson(params);
    // The description and the grid must agree: an edited n, voxels-per-cell or cube-size
    // would otherwise silently rescale every rock.
    const double dx = rho.voxelSize()[0], expected = set.params.voxelSize();
    if (!(std::abs(dx - expected) <= 1e-6 * expected)) {
        fail<ValueError>("rockpile: grid '", rho.getName(), "' has voxels of ", dx, " m but its tile set "
                         "description (n = ", set.params.n, ", voxels-per-cell = ", set.params.voxelsPerCell,
                         ", cube-size = ", set.params.cubeSize, " m) means ", expected,
                         " m: the metadata was edited or belongs to another grid");
    }
    auto acc = rho.getConstAccessor();
    for (const auto& rj : j.at("rocks")) {
        Rock r;
        r.seed.key = std::stoull(rj.at("key").get<std::string>(), nullptr, 16);
        for (int a = 0; a < 3; ++a) {
            r.seed.p[a] = rj.at("seed").at(a).get<double>();
            r.origin[a] = rj.at("origin").at(a).get<int>();
            r.dims[a] = rj.at("dims").at(a).get<int>();
        }
        if (r.dims[0] < 0 || r.dims[1] < 0 || r.dims[2] < 0 ||
            double(r.dims[0]) * r.dims[1] * r.dims[2] > 1e7) {
            fail<ValueError>("rockpile: tile set rock box out of range");
        }
        const Coord off(rj.at("offset").at(0).get<int>(), rj.at("offset").at(1).get<int>(),
                        rj.at("offset").at(2).get<int>());
        r.voronoiVoxels = rj.value("voronoi", size_t(0));
        r.rho.resize(size_t(r.dims[0]) * r.dims[1] * r.dims[2]);
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)] =
                        acc.getValue(r.origin.offsetBy(x, y, z) + off);
                }
        set.rocks.push_back(std::move(r));
    }
    for (const auto& gj : j.at("regions")) {
        Region g;
        g.type = gj.at("type").get<int>();
        g.axes = gj.at("axes").get<std::array<int, 3>>();
        g.colours = gj.at("colours").get<std::vector<int>>();
        g.rocks = gj.at("rocks").get<std::vector<size_t>>();
        for (size_t i : g.rocks) {
            if (i >= set.rocks.size()) fail<ValueError>("rockpile: tile set region names rock ", i, " of ", set.rocks.size());
        }
        set.regions.push_back(std::move(g));
    }
    const auto& st = j.at("stats");
    set.stats.stones = st.value("stones", size_t(0));
    set.stats.regions = set.regions.size();
    set.stats.seeds = set.rocks.size();
    set.stats.contacts = st.value("contacts", size_t(0));
    return set;
}

} // namespace rockpile
} // namespace rockvdb
