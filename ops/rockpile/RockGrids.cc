// SPDX-License-Identifier: Apache-2.0
// Rock tiles as grids: each rock's level set (from its density ρ), the library of every rock's
// level set in its own slot, and the tile set file (the ρ atlas with its description).
#include <rockvdb/core/Json.h>
#include <rockvdb/rockpile/RockTiles.h>
#include <rockvdb/rockpile/RockPile.h>

#include <rockvdb/core/Corrupt.h>
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

openvdb::FloatGrid::Ptr libraryGrid(const TileSet& set, double halfWidth, double* seconds,
                                    openvdb::FloatGrid::Ptr* ids)
{
    Task task;
    return libraryGrid(set, task, halfWidth, seconds, ids);
}

std::vector<Vec3d> librarySeeds(const TileSet& set, double halfWidth)
{
    const std::vector<Coord> offsets = atlasOffsets(set, int(std::ceil(halfWidth)) + 1);
    std::vector<Vec3d> seeds(offsets.size());
    for (size_t i = 0; i < offsets.size(); ++i) seeds[i] = seedWorld(set, set.rocks[i], offsets[i]);
    return seeds;
}

openvdb::FloatGrid::Ptr libraryGrid(const TileSet& set, Task& task, double halfWidth,
                                    double* seconds, openvdb::FloatGrid::Ptr* ids)
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
    if (ids) {
        // Rocks never share a leaf (atlasOffsets): each leaf's voxels carry its rock's index.
        *ids = openvdb::FloatGrid::create(-1.0f);
        (*ids)->setTransform(library->transform().copy());
        (*ids)->setName("rock_id");
        (*ids)->setGridClass(openvdb::GRID_UNKNOWN);
        for (size_t i = 0; i < count; ++i) {
            for (const LeafT* leaf : leaves[i]) {
                auto* id = new LeafT(leaf->origin(), -1.0f);
                for (auto it = leaf->cbeginValueOn(); it; ++it) id->setValueOn(it.pos(), float(i));
                (*ids)->tree().addLeaf(id);
            }
        }
    }
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

TileSet tilesFromGrid(const openvdb::FloatGrid& rho, const std::string& file)
{
    const std::string what = file.empty() ? "rock tile set grid '" + rho.getName() + "'"
                                          : "rock tile set '" + file + "'";
    const auto meta = rho.getMetadata<openvdb::StringMetadata>("rockvdb:tiles");
    if (!meta) fail<ValueError>("rockpile: grid '", rho.getName(), "' holds no tile set (no rockvdb:tiles metadata)");
    // Every value is checked before anything is sized from it (issue 40): a wrong one is
    // named with its key, an IoError (the file is corrupt).
    const Corrupt c(what, "rockvdb:tiles");
    const nlohmann::json j = parseJsonOrDiscarded(meta->value());
    if (j.is_discarded()) c.fail("", "is not JSON");
    if (c.integer(c.at(j, "", "format"), "format", 0, INT32_MAX) != 1) {
        c.fail("format", "is " + j["format"].dump() + " (this build reads format 1)");
    }
    TileSet set;
    try {
        // Format 1 files written before the parameter tables spelt keys with '_'.
        nlohmann::json params = nlohmann::json::object();
        const nlohmann::json& jp = c.at(j, "", "params");
        if (!jp.is_object()) c.fail("params", "is not an object");
        for (auto it = jp.begin(); it != jp.end(); ++it) {
            std::string key = it.key();
            std::replace(key.begin(), key.end(), '_', '-');
            params[key] = it.value();
        }
        set.params = RockTileParams::fromJson(params);
    } catch (const ValueError& e) {
        c.fail("params", std::string("are not a tile set's: ") + e.what());
    }
    // The description and the grid must agree: an edited n, voxels-per-cell or cube-size
    // would otherwise silently rescale every rock.
    const double dx = rho.voxelSize()[0], expected = set.params.voxelSize();
    if (!(std::abs(dx - expected) <= 1e-6 * expected)) {
        fail<IoError>("corrupt ", what, ": the grid has voxels of ", dx, " m but its tile set "
                      "description (n = ", set.params.n, ", voxels-per-cell = ", set.params.voxelsPerCell,
                      ", cube-size = ", set.params.cubeSize, " m) means ", expected,
                      " m: the metadata was edited or belongs to another grid");
    }
    // Rock boxes against the grid they are read from: each lies in the grid's active box
    // (within 4 voxels: a box keeps the empty voxels around its rock), in its own atlas slot
    // (their volumes sum to at most the box's), so no size here exceeds what the grid holds.
    const openvdb::CoordBBox active = rho.evalActiveVoxelBoundingBox();
    openvdb::CoordBBox room = active;
    if (!room.empty()) room.expand(4);
    const double roomVolume = room.empty() ? 0.0 : double(room.volume());
    const nlohmann::json& rocks = c.array(c.at(j, "", "rocks"), "rocks", 0,
                                          size_t(std::min<openvdb::Index64>(rho.activeVoxelCount(), 1u << 24)));
    const double n = set.params.n;
    double volume = 0;
    auto acc = rho.getConstAccessor();
    for (size_t i = 0; i < rocks.size(); ++i) {
        const std::string k = Corrupt::item("rocks", i);
        const nlohmann::json& rj = rocks[i];
        Rock r;
        const std::string key = c.string(c.at(rj, k, "key"), k + ".key");
        if (key.empty() || key.size() > 16 || key.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos) {
            c.fail(k + ".key", "is '" + key.substr(0, 20) + "' (expected up to 16 hex digits)");
        }
        r.seed.key = std::stoull(key, nullptr, 16);
        const nlohmann::json& seed = c.array(c.at(rj, k, "seed"), k + ".seed", 3, 3);
        const nlohmann::json& origin = c.array(c.at(rj, k, "origin"), k + ".origin", 3, 3);
        const nlohmann::json& dims = c.array(c.at(rj, k, "dims"), k + ".dims", 3, 3);
        const nlohmann::json& offset = c.array(c.at(rj, k, "offset"), k + ".offset", 3, 3);
        openvdb::Coord off;
        for (size_t a = 0; a < 3; ++a) {
            r.seed.p[int(a)] = c.number(seed[a], Corrupt::item(k + ".seed", a), -2 * n, 3 * n);
            r.origin[int(a)] = int(c.integer(origin[a], Corrupt::item(k + ".origin", a), -(1 << 24), 1 << 24));
            r.dims[int(a)] = int(c.integer(dims[a], Corrupt::item(k + ".dims", a), 1, 1 << 16));
            off[int(a)] = int(c.integer(offset[a], Corrupt::item(k + ".offset", a), -(1 << 24), 1 << 24));
        }
        const openvdb::CoordBBox box(r.origin + off, r.origin + off + r.dims - openvdb::Coord(1));
        if (!room.isInside(box)) {
            auto str = [](const openvdb::Coord& q) {
                return "(" + std::to_string(q[0]) + ", " + std::to_string(q[1]) + ", " + std::to_string(q[2]) + ")";
            };
            c.fail(k, "has a box " + str(box.min()) + ".." + str(box.max()) +
                          " outside the grid's voxels " + str(active.min()) + ".." + str(active.max()));
        }
        volume += double(box.volume());
        if (volume > roomVolume) {
            c.fail("rocks", "boxes hold more voxels than the grid's box (" + std::to_string(size_t(roomVolume)) + ")");
        }
        if (rj.contains("voronoi")) r.voronoiVoxels = size_t(c.integer(rj["voronoi"], k + ".voronoi", 0, int64_t(1) << 40));
        r.rho.resize(size_t(r.dims[0]) * r.dims[1] * r.dims[2]);
        for (int x = 0; x < r.dims[0]; ++x)
            for (int y = 0; y < r.dims[1]; ++y)
                for (int z = 0; z < r.dims[2]; ++z) {
                    r.rho[size_t((x * r.dims[1] + y) * r.dims[2] + z)] =
                        acc.getValue(r.origin.offsetBy(x, y, z) + off);
                }
        set.rocks.push_back(std::move(r));
    }
    const nlohmann::json& regions = c.array(c.at(j, "", "regions"), "regions", 0, 1u << 16);
    for (size_t i = 0; i < regions.size(); ++i) {
        const std::string k = Corrupt::item("regions", i);
        const nlohmann::json& gj = regions[i];
        Region g;
        g.type = int(c.integer(c.at(gj, k, "type"), k + ".type", 0, 3));
        const nlohmann::json& axes = c.array(c.at(gj, k, "axes"), k + ".axes", 3, 3);
        for (size_t a = 0; a < 3; ++a) g.axes[a] = int(c.integer(axes[a], Corrupt::item(k + ".axes", a), 0, 1));
        const nlohmann::json& colours = c.array(c.at(gj, k, "colours"), k + ".colours", 0, 64);
        for (size_t m = 0; m < colours.size(); ++m) {
            g.colours.push_back(int(c.integer(colours[m], Corrupt::item(k + ".colours", m), 0, 63)));
        }
        const nlohmann::json& rr = c.array(c.at(gj, k, "rocks"), k + ".rocks", 0, set.rocks.size());
        for (size_t m = 0; m < rr.size(); ++m) {
            g.rocks.push_back(size_t(c.integer(rr[m], Corrupt::item(k + ".rocks", m), 0,
                                               int64_t(set.rocks.size()) - 1)));
        }
        set.regions.push_back(std::move(g));
    }
    const nlohmann::json& st = c.at(j, "", "stats");
    auto count = [&](const char* name) {
        return st.contains(name) ? size_t(c.integer(st[name], std::string("stats.") + name, 0, int64_t(1) << 40)) : size_t(0);
    };
    set.stats.stones = count("stones");
    set.stats.regions = set.regions.size();
    set.stats.seeds = set.rocks.size();
    set.stats.contacts = count("contacts");
    return set;
}

} // namespace rockpile
} // namespace rockvdb
