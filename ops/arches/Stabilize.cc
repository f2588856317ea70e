// SPDX-License-Identifier: Apache-2.0
// Stabilisation of material stacks (see Stabilize.h).
#include "Stabilize.h"

#include <rockvdb/core/Error.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>

namespace rockvdb {
namespace arches {

namespace {

constexpr uint64_t kSky = std::numeric_limits<uint64_t>::max() / 4; // the top segment's ceiling

// The room between two bedrock layers (quanta above z0) and the granular material in it,
// sorted from the floor up: sand, rocks, water, then air.
struct Segment
{
    uint64_t floor = 0, ceiling = kSky;
    uint64_t sand = 0, rocks = 0, water = 0;

    uint64_t filled() const { return sand + rocks + water; }
    uint64_t room() const { return ceiling == kSky ? kSky : ceiling - floor - filled(); }
};

// Every stack as its segments (bedrock is what lies between them).
struct Segments
{
    StackGeometry geometry;
    std::vector<uint32_t> first; // per stack: its first segment
    std::vector<Segment> seg;

    explicit Segments(const Stacks& st) : geometry(st.geometry())
    {
        const auto& g = geometry;
        first.resize(g.count() + 1);
        st.forEachStack([&](size_t s, const uint16_t* codes, size_t n) {
            first[s] = uint32_t(seg.size());
            Segment cur;
            uint64_t z = 0;
            for (size_t c = 0; c < n; ++c) {
                const Material m = Stacks::codeMaterial(codes[c]);
                const uint32_t t = Stacks::codeThickness(codes[c]);
                if (m == Material::Bedrock) {
                    // Close the room below this bedrock (kept when it has any height; a run
                    // of bedrock codes leaves none between them).
                    if (z > cur.floor) {
                        cur.ceiling = z;
                        seg.push_back(cur);
                    }
                    z += t;
                    cur = Segment{};
                    cur.floor = z;
                    continue;
                }
                if (m == Material::Sand) cur.sand += t;
                else if (m == Material::Rocks) cur.rocks += t;
                else if (m == Material::Water) cur.water += t;
                z += t;
            }
            cur.ceiling = kSky;
            seg.push_back(cur);
        });
        first[g.count()] = uint32_t(seg.size());
    }

    // The segment of stack s whose room contains height h (quanta), or -1 (inside bedrock).
    int64_t at(size_t s, uint64_t h) const
    {
        for (uint32_t k = first[s]; k < first[s + 1]; ++k) {
            if (seg[k].floor <= h && h < seg[k].ceiling) return int64_t(k);
        }
        return -1;
    }

    // Stack s's layers from its segments (bedrock between them).
    void layersOf(size_t s, std::vector<Layer>& layers) const
    {
        uint64_t z = 0;
        for (uint32_t k = first[s]; k < first[s + 1]; ++k) {
            const Segment& c = seg[k];
            auto add = [&](Material m, uint64_t t) {
                for (; t > 0;) { // Layer thickness is 32-bit
                    const uint32_t part = uint32_t(std::min<uint64_t>(t, 0xffffffffu));
                    layers.push_back(Layer{m, part});
                    t -= part;
                }
            };
            add(Material::Bedrock, c.floor - z);
            add(Material::Sand, c.sand);
            add(Material::Rocks, c.rocks);
            add(Material::Water, c.water);
            if (c.ceiling != kSky) add(Material::Air, c.ceiling - c.floor - c.filled());
            z = c.ceiling;
        }
    }

    Stacks encode(Task& task) const
    {
        return Stacks::build(geometry, [&](int i, int j, std::vector<Layer>& layers) {
            layersOf(geometry.index(i, j), layers);
        }, task);
    }
};

const int kDx[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
const int kDy[8] = {-1, -1, -1, 0, 0, 1, 1, 1};

// One material's slide: a FIFO worklist, one thread. The worklist starts with every segment
// holding the material, or with those of @a seeds' stacks (in that order). A local run
// (@a rim given) returns false, having changed what it must then discard, as soon as it would
// evaluate a segment of a rim stack (the window's edge where the grid goes on, whose
// neighbours it cannot see). @a touched (optional) marks every stack whose segments changed.
bool slide(Segments& S, Material material, double angleDegrees, Task& task, StabilizeStats& stats,
           const std::vector<uint32_t>* seeds = nullptr, const std::vector<uint8_t>* rim = nullptr,
           std::vector<uint8_t>* touched = nullptr)
{
    const auto& g = S.geometry;
    const bool sand = material == Material::Sand;
    const double tanA = std::tan(angleDegrees * M_PI / 180.0);
    // Thresholds per neighbour (quanta): d_i · tan α.
    double threshold[8];
    for (int n = 0; n < 8; ++n) {
        const double d = (kDx[n] != 0 && kDy[n] != 0) ? g.cell * std::sqrt(2.0) : g.cell;
        threshold[n] = d * tanA / g.quantum;
    }
    auto amount = [&](Segment& c) -> uint64_t& { return sand ? c.sand : c.rocks; };
    auto top = [&](const Segment& c) { return c.floor + c.sand + (sand ? 0 : c.rocks); };

    std::vector<uint8_t> queued(S.seg.size(), 0);
    std::deque<uint32_t> work;
    auto seed = [&](uint32_t k) {
        if (amount(S.seg[k]) > 0 && !queued[k]) {
            work.push_back(k);
            queued[k] = 1;
        }
    };
    if (seeds) {
        for (const uint32_t st : *seeds)
            for (uint32_t k = S.first[st]; k < S.first[st + 1]; ++k) seed(k);
    } else {
        for (uint32_t k = 0; k < S.seg.size(); ++k) seed(k);
    }
    // The stack of each segment, for neighbour lookups.
    std::vector<uint32_t> stackOf(S.seg.size());
    for (size_t s = 0; s < g.count(); ++s)
        for (uint32_t k = S.first[s]; k < S.first[s + 1]; ++k) stackOf[k] = uint32_t(s);

    struct Out
    {
        uint32_t seg;
        double excess;
        uint64_t room;
        uint64_t take = 0;
    };
    std::vector<Out> outs;
    auto push = [&](uint32_t k) {
        if (!queued[k]) {
            queued[k] = 1;
            work.push_back(k);
        }
    };
    size_t sinceCheck = 0;
    while (!work.empty()) {
        if (++sinceCheck == 4096) {
            sinceCheck = 0;
            task.check();
        }
        const uint32_t c = work.front();
        work.pop_front();
        queued[c] = 0;
        ++stats.visits;
        Segment& cs = S.seg[c];
        const uint64_t have = amount(cs);
        if (have == 0) continue;
        const uint64_t h = top(cs);
        const size_t s = stackOf[c];
        if (rim && (*rim)[s]) return false;
        const int i = int(s % size_t(g.nx)), j = int(s / size_t(g.nx));
        outs.clear();
        double maxExcess = 0, sum = 0;
        for (int n = 0; n < 8; ++n) {
            const int ni = i + kDx[n], nj = j + kDy[n];
            if (ni < 0 || nj < 0 || ni >= g.nx || nj >= g.ny) continue;
            const int64_t k = S.at(g.index(ni, nj), h);
            if (k < 0) continue; // a wall
            const Segment& ns = S.seg[size_t(k)];
            const uint64_t room = ns.room();
            if (room == 0) continue;
            const double excess = double(h) - double(top(ns)) - threshold[n];
            if (excess <= 0) continue;
            outs.push_back(Out{uint32_t(k), excess, room});
            maxExcess = std::max(maxExcess, excess);
            sum += excess;
        }
        if (maxExcess < 1.0) continue; // stable within a quantum
        uint64_t move = std::min<uint64_t>(have, std::max<uint64_t>(1, uint64_t(maxExcess / 2.0)));
        // In proportion to the excess, within each neighbour's room; the rounding remainder to
        // the largest excesses first (ties: neighbour order).
        uint64_t given = 0;
        for (Out& o : outs) {
            o.take = std::min(o.room, uint64_t(double(move) * o.excess / sum));
            given += o.take;
        }
        std::vector<size_t> order(outs.size());
        for (size_t o = 0; o < order.size(); ++o) order[o] = o;
        std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return outs[a].excess > outs[b].excess; });
        for (bool progress = true; given < move && progress;) {
            progress = false;
            for (size_t o : order) {
                if (given == move) break;
                if (outs[o].take < outs[o].room) {
                    ++outs[o].take;
                    ++given;
                    progress = true;
                }
            }
        }
        if (given == 0) continue;
        amount(cs) -= given;
        for (const Out& o : outs) amount(S.seg[o.seg]) += o.take;
        if (touched) {
            (*touched)[s] = 1;
            for (const Out& o : outs) (*touched)[stackOf[o.seg]] = 1;
        }
        ++stats.moves;
        stats.movedQuanta += given;
        // Whatever stands next to a changed pile may now slide: the giver, the receivers and
        // every neighbouring pile whose top lies in the giver's room (it slides into that
        // room, now lower; a pile up a slope stands above the giver's old top, so looking up
        // the neighbours' segments at that height alone missed it).
        push(c);
        for (const Out& o : outs) push(o.seg);
        for (int n = 0; n < 8; ++n) {
            const int ni = i + kDx[n], nj = j + kDy[n];
            if (ni < 0 || nj < 0 || ni >= g.nx || nj >= g.ny) continue;
            const size_t ns = g.index(ni, nj);
            for (uint32_t k = S.first[ns]; k < S.first[ns + 1]; ++k) {
                const Segment& o = S.seg[k];
                const uint64_t t = top(o);
                if (amount(S.seg[k]) > 0 && t >= cs.floor && t < cs.ceiling) push(k);
            }
        }
    }
    return true;
}

} // namespace

void ReposeAngles::validate() const
{
    if (!(sand > 0 && sand < 90)) fail<ValueError>("arches: repose angle of sand must be in (0, 90) degrees (got ", sand, ")");
    if (!(rocks > 0 && rocks < 90)) fail<ValueError>("arches: repose angle of rocks must be in (0, 90) degrees (got ", rocks, ")");
}

Stacks normalizeStacks(const Stacks& stacks, Task& task)
{
    return Segments(stacks).encode(task);
}

Stacks stabilizeStacks(const Stacks& stacks, const ReposeAngles& angles, Task& task,
                       StabilizeStats* stats)
{
    angles.validate();
    const auto t0 = std::chrono::steady_clock::now();
    StabilizeStats local;
    Segments S(stacks);
    // Bottom layers first: sand, then the rocks lying on it.
    task.phase("sand", 0.5);
    slide(S, Material::Sand, angles.sand, task, local);
    task.phase("rocks", 0.4);
    slide(S, Material::Rocks, angles.rocks, task, local);
    task.phase("encode", 0.1);
    Stacks r = S.encode(task);
    local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (stats) *stats = local;
    return r;
}

StabilizeStats stabilizeLocal(Stacks& stacks, const ReposeAngles& angles, int i0, int j0, int i1, int j1,
                              Task& task)
{
    angles.validate();
    const auto t0 = std::chrono::steady_clock::now();
    const auto& g = stacks.geometry();
    // The changed stacks and their 8 neighbours (a stack beside a carved one may now slide).
    const int si0 = std::max(0, i0 - 1), sj0 = std::max(0, j0 - 1);
    const int si1 = std::min(g.nx - 1, i1 + 1), sj1 = std::min(g.ny - 1, j1 + 1);
    if (si0 > si1 || sj0 > sj1) return StabilizeStats{};
    for (int margin = 8;; margin *= 2) {
        task.check();
        const int wi0 = std::max(0, si0 - margin), wj0 = std::max(0, sj0 - margin);
        const int wi1 = std::min(g.nx - 1, si1 + margin), wj1 = std::min(g.ny - 1, sj1 + margin);
        Segments S(stacks.window(wi0, wj0, wi1, wj1, task));
        const int nx = wi1 - wi0 + 1, ny = wj1 - wj0 + 1;
        std::vector<uint8_t> rim(size_t(nx) * size_t(ny), 0), touched(rim.size(), 0);
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                rim[size_t(j) * size_t(nx) + size_t(i)] = uint8_t((i == 0 && wi0 > 0) || (j == 0 && wj0 > 0) ||
                                                                  (i == nx - 1 && wi1 < g.nx - 1) ||
                                                                  (j == ny - 1 && wj1 < g.ny - 1));
            }
        std::vector<uint32_t> seeds;
        for (int j = sj0; j <= sj1; ++j)
            for (int i = si0; i <= si1; ++i) {
                const size_t s = size_t(j - wj0) * size_t(nx) + size_t(i - wi0);
                seeds.push_back(uint32_t(s));
                touched[s] = 1; // written back merged and sorted, moved or not
            }
        StabilizeStats local;
        if (!slide(S, Material::Sand, angles.sand, task, local, &seeds, &rim, &touched)) continue;
        // Rocks: from the seeds and every stack the sand changed (rocks lie on sand).
        std::vector<uint32_t> rockSeeds;
        for (uint32_t s = 0; s < touched.size(); ++s) {
            if (touched[s]) rockSeeds.push_back(s);
        }
        if (!slide(S, Material::Rocks, angles.rocks, task, local, &rockSeeds, &rim, &touched)) continue;
        stacks.edit(wi0, wj0, wi1, wj1, [&](int i, int j, std::vector<Layer>& layers) {
            const size_t s = size_t(j - wj0) * size_t(nx) + size_t(i - wi0);
            if (!touched[s]) return false;
            layers.clear();
            S.layersOf(s, layers);
            return true;
        });
        local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        return local;
    }
}

double largestExcess(const Stacks& stacks, Material material, double angleDegrees)
{
    const Segments S(stacks);
    const auto& g = S.geometry;
    const bool sand = material == Material::Sand;
    const double tanA = std::tan(angleDegrees * M_PI / 180.0);
    double worst = 0;
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i) {
            const size_t s = g.index(i, j);
            for (uint32_t k = S.first[s]; k < S.first[s + 1]; ++k) {
                const Segment& c = S.seg[k];
                if ((sand ? c.sand : c.rocks) == 0) continue;
                const uint64_t h = c.floor + c.sand + (sand ? 0 : c.rocks);
                for (int n = 0; n < 8; ++n) {
                    const int ni = i + kDx[n], nj = j + kDy[n];
                    if (ni < 0 || nj < 0 || ni >= g.nx || nj >= g.ny) continue;
                    const int64_t o = S.at(g.index(ni, nj), h);
                    if (o < 0 || S.seg[size_t(o)].room() == 0) continue;
                    const Segment& ns = S.seg[size_t(o)];
                    const double d = (kDx[n] != 0 && kDy[n] != 0) ? g.cell * std::sqrt(2.0) : g.cell;
                    const double top = double(ns.floor + ns.sand + (sand ? 0 : ns.rocks));
                    worst = std::max(worst, double(h) - top - d * tanA / g.quantum);
                }
            }
        }
    return worst;
}

} // namespace arches
} // namespace rockvdb
