// SPDX-License-Identifier: Apache-2.0
// Material stacks and their skeletons (see Stacks.h).
#include "Stacks.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace rockvdb {
namespace arches {

namespace {

const char* const kNames[kMaterialCount] = {"air", "water", "sand", "bedrock", "rocks"};

} // namespace

const char* materialName(Material m)
{
    return unsigned(m) < unsigned(kMaterialCount) ? kNames[unsigned(m)] : "?";
}

Material materialFromName(const std::string& name, const std::string& what)
{
    for (int m = 0; m < kMaterialCount; ++m) {
        if (name == kNames[m]) return Material(m);
    }
    fail<ValueError>(what, ": unknown material '", name, "' (known: air, water, sand, bedrock, rocks)");
}

void StackGeometry::validate() const
{
    auto finite = [](double v) { return std::isfinite(v); };
    if (nx < 1 || ny < 1) fail<ValueError>("stacks: the grid needs at least one stack along x and y (got ", nx, " x ", ny, ")");
    if (!(cell > 0) || !finite(cell)) fail<ValueError>("stacks: cell size must be > 0 (got ", cell, ")");
    if (!(quantum > 0) || !finite(quantum)) fail<ValueError>("stacks: thickness quantum must be > 0 (got ", quantum, ")");
    if (!finite(x0) || !finite(y0) || !finite(z0)) fail<ValueError>("stacks: the origin must be finite");
}

bool StackGeometry::operator==(const StackGeometry& o) const
{
    return nx == o.nx && ny == o.ny && cell == o.cell && x0 == o.x0 && y0 == o.y0 && z0 == o.z0 &&
           quantum == o.quantum;
}

Stacks Stacks::build(const StackGeometry& geometry,
                     const std::function<void(int, int, std::vector<Layer>&)>& column, Task& task,
                     double maxMemoryBytes)
{
    geometry.validate();
    // At least a count byte, one code and the row buffers' share per stack, built and copied.
    const double estimate = double(geometry.count()) * (1.0 + 2.0) * 2.0 + double(geometry.ny) * 64.0;
    const double limit = memoryLimitBytes(maxMemoryBytes);
    if (estimate > limit) {
        fail<ValueError>("stacks: ", geometry.nx, " x ", geometry.ny, " stacks need at least ", formatBytes(estimate),
                         ", over the ", formatBytes(limit), " allowed; use a larger cell size or a smaller extent, or raise --max-memory");
    }
    // 1. Each row's codes (runs split at kMaxCode), rows in parallel.
    std::vector<std::vector<uint16_t>> rows(size_t(geometry.ny));
    std::vector<std::vector<uint8_t>> counts(size_t(geometry.ny));
    parallelFor(task, size_t(geometry.ny), 1, [&](size_t j) {
        std::vector<Layer> layers;
        auto& codes = rows[j];
        auto& count = counts[j];
        count.resize(size_t(geometry.nx));
        for (int i = 0; i < geometry.nx; ++i) {
            layers.clear();
            column(i, int(j), layers);
            count[size_t(i)] = uint8_t(appendCodes(i, int(j), layers, codes));
        }
    });
    Stacks r;
    r.mGeometry = geometry;
    r.mCount.reserve(geometry.count());
    std::vector<uint16_t> all;
    for (size_t j = 0; j < rows.size(); ++j) {
        all.insert(all.end(), rows[j].begin(), rows[j].end());
        r.mCount.insert(r.mCount.end(), counts[j].begin(), counts[j].end());
        std::vector<uint16_t>().swap(rows[j]);
    }
    r.mCodes = all.size();
    // 2. Blocks of 64 stacks byte-coded in parallel, each against its stacks' predecessors.
    const size_t n = geometry.count(), blocks = (n + kBlock - 1) / kBlock;
    std::vector<size_t> first(n + 1, 0);
    for (size_t s2 = 0; s2 < n; ++s2) first[s2 + 1] = first[s2] + r.mCount[s2];
    std::vector<std::vector<uint8_t>> coded(blocks);
    parallelFor(task, blocks, 16, [&](size_t b) {
        std::vector<uint16_t> prev;
        for (size_t s2 = b * kBlock; s2 < std::min(n, (b + 1) * kBlock); ++s2) {
            if (s2 == b * kBlock) prev.clear();
            encodeStack(prev, all.data() + first[s2], r.mCount[s2], coded[b]);
            prev.assign(all.begin() + std::ptrdiff_t(first[s2]), all.begin() + std::ptrdiff_t(first[s2 + 1]));
        }
    });
    r.mBlock.resize(blocks);
    size_t total = 0;
    for (size_t b = 0; b < blocks; ++b) {
        if (total > std::numeric_limits<uint32_t>::max()) fail<ValueError>("stacks: the code stream exceeds 4 GB");
        r.mBlock[b] = uint32_t(total);
        total += coded[b].size();
    }
    r.mStream.reserve(total);
    for (auto& c : coded) {
        r.mStream.insert(r.mStream.end(), c.begin(), c.end());
        std::vector<uint8_t>().swap(c);
    }
    return r;
}

size_t Stacks::appendCodes(int i, int j, const std::vector<Layer>& layers, std::vector<uint16_t>& codes)
{
    const size_t before = codes.size();
    Material last = Material::Air;
    uint64_t pending = 0;
    auto flush = [&] {
        while (pending > 0) {
            const uint32_t t = uint32_t(std::min<uint64_t>(pending, kMaxCode));
            codes.push_back(code(last, t));
            pending -= t;
        }
    };
    for (const Layer& l : layers) {
        if (l.thickness == 0) continue;
        if (unsigned(l.material) >= unsigned(kMaterialCount)) {
            fail<ValueError>("stacks: stack (", i, ", ", j, ") has an unknown material id ", unsigned(l.material));
        }
        if (pending > 0 && l.material != last) flush();
        last = l.material;
        pending += l.thickness;
    }
    flush();
    // Air on top is implied: drop it.
    while (codes.size() > before && codeMaterial(codes.back()) == Material::Air) codes.pop_back();
    if (codes.size() - before > 255) {
        const size_t n = codes.size() - before;
        codes.resize(before);
        fail<ValueError>("stacks: stack (", i, ", ", j, ") needs ", n,
                         " layer codes, more than the 255 a stack holds; use a larger thickness quantum");
    }
    return codes.size() - before;
}

Stacks Stacks::window(int i0, int j0, int i1, int j1, Task& task) const
{
    const auto& g = mGeometry;
    i0 = std::max(i0, 0);
    j0 = std::max(j0, 0);
    i1 = std::min(i1, g.nx - 1);
    j1 = std::min(j1, g.ny - 1);
    if (i0 > i1 || j0 > j1) fail<ValueError>("stacks: the window holds no stack");
    StackGeometry w = g;
    w.nx = i1 - i0 + 1;
    w.ny = j1 - j0 + 1;
    w.x0 = g.x0 + i0 * g.cell;
    w.y0 = g.y0 + j0 * g.cell;
    return build(w, [&](int i, int j, std::vector<Layer>& layers) { this->layers(i0 + i, j0 + j, layers); }, task);
}

size_t Stacks::edit(int i0, int j0, int i1, int j1,
                    const std::function<bool(int i, int j, std::vector<Layer>& layers)>& change)
{
    const auto& g = mGeometry;
    i0 = std::max(i0, 0);
    j0 = std::max(j0, 0);
    i1 = std::min(i1, g.nx - 1);
    j1 = std::min(j1, g.ny - 1);
    if (i0 > i1 || j0 > j1) return 0;
    // The blocks the window meets, in order.
    std::vector<size_t> blocks;
    for (int j = j0; j <= j1; ++j) {
        for (size_t b = g.index(i0, j) / kBlock; b <= g.index(i1, j) / kBlock; ++b) {
            if (blocks.empty() || blocks.back() != b) blocks.push_back(b);
        }
    }
    const size_t n = mCount.size();
    struct Recoded
    {
        size_t block;
        std::vector<uint8_t> bytes, counts;
        int64_t codes; // change in the code total
    };
    std::vector<Recoded> out;
    size_t changed = 0;
    std::vector<uint16_t> prev, cur, codes;
    std::vector<Layer> layers;
    for (const size_t b : blocks) {
        const size_t first = b * kBlock, last = std::min(n, first + kBlock);
        // Decode the block, let change rewrite the window's stacks.
        std::vector<std::vector<uint16_t>> stack(last - first);
        size_t at = mBlock[b];
        prev.clear();
        bool any = false;
        int64_t delta = 0;
        for (size_t s = first; s < last; ++s) {
            at = decodeStack(mStream, at, mCount[s], prev, cur);
            prev = cur;
            const int i = int(s % size_t(g.nx)), j = int(s / size_t(g.nx));
            if (i >= i0 && i <= i1 && j >= j0 && j <= j1) {
                layers.clear();
                for (const uint16_t c : cur) {
                    const Material m = codeMaterial(c);
                    if (!layers.empty() && layers.back().material == m) layers.back().thickness += codeThickness(c);
                    else layers.push_back(Layer{m, codeThickness(c)});
                }
                if (change(i, j, layers)) {
                    codes.clear();
                    appendCodes(i, j, layers, codes);
                    if (codes != cur) {
                        delta += int64_t(codes.size()) - int64_t(cur.size());
                        cur = codes;
                        any = true;
                        ++changed;
                    }
                }
            }
            stack[s - first] = cur;
        }
        if (!any) continue;
        Recoded r{b, {}, {}, delta};
        prev.clear();
        for (size_t s = first; s < last; ++s) {
            encodeStack(prev, stack[s - first].data(), stack[s - first].size(), r.bytes);
            r.counts.push_back(uint8_t(stack[s - first].size()));
            prev = stack[s - first];
        }
        out.push_back(std::move(r));
    }
    if (out.empty()) return 0;
    // Splice: the untouched blocks' bytes as they are, the re-encoded ones in their place.
    std::vector<uint8_t> stream;
    size_t total = mStream.size();
    for (const auto& r : out) {
        const size_t from = mBlock[r.block], to = r.block + 1 < mBlock.size() ? mBlock[r.block + 1] : mStream.size();
        total = total - (to - from) + r.bytes.size();
    }
    if (total > std::numeric_limits<uint32_t>::max()) fail<ValueError>("stacks: the code stream exceeds 4 GB");
    stream.reserve(total);
    std::vector<uint32_t> block(mBlock.size());
    size_t next = 0;
    for (size_t b = 0; b < mBlock.size(); ++b) {
        block[b] = uint32_t(stream.size());
        if (next < out.size() && out[next].block == b) {
            stream.insert(stream.end(), out[next].bytes.begin(), out[next].bytes.end());
            ++next;
        } else {
            const size_t from = mBlock[b], to = b + 1 < mBlock.size() ? mBlock[b + 1] : mStream.size();
            stream.insert(stream.end(), mStream.begin() + std::ptrdiff_t(from), mStream.begin() + std::ptrdiff_t(to));
        }
    }
    for (const auto& r : out) {
        std::copy(r.counts.begin(), r.counts.end(), mCount.begin() + std::ptrdiff_t(r.block * kBlock));
        mCodes = size_t(int64_t(mCodes) + r.codes);
    }
    mStream.swap(stream);
    mBlock.swap(block);
    return changed;
}

void Stacks::encodeStack(const std::vector<uint16_t>& prev, const uint16_t* codes, size_t n,
                         std::vector<uint8_t>& out)
{
    for (size_t k = 0; k < n; ++k) {
        const unsigned m = unsigned(codeMaterial(codes[k]));
        const int t = int(codeThickness(codes[k]));
        if (k < prev.size() && unsigned(codeMaterial(prev[k])) == m) {
            const int d = t - int(codeThickness(prev[k]));
            if (d >= -64 && d <= 63) {
                out.push_back(uint8_t(d + 64));
                continue;
            }
        }
        out.push_back(uint8_t(0x80u | (m << 4) | unsigned(t >> 8)));
        out.push_back(uint8_t(t & 0xff));
    }
}

size_t Stacks::decodeStack(const std::vector<uint8_t>& stream, size_t at, size_t n,
                           const std::vector<uint16_t>& prev, std::vector<uint16_t>& out)
{
    out.clear();
    for (size_t k = 0; k < n; ++k) {
        if (at >= stream.size()) fail<ValueError>("stacks: the code stream ends inside a stack");
        const uint8_t b = stream[at++];
        unsigned m;
        int t;
        if (b & 0x80u) {
            if (at >= stream.size()) fail<ValueError>("stacks: the code stream ends inside a code");
            m = (b >> 4) & 7u;
            t = int((b & 0x0fu) << 8) | int(stream[at++]);
        } else {
            if (k >= prev.size()) fail<ValueError>("stacks: a delta code with no layer below it in the previous stack");
            m = unsigned(codeMaterial(prev[k]));
            t = int(codeThickness(prev[k])) + int(b) - 64;
        }
        if (m >= unsigned(kMaterialCount) || t < 1 || t > int(kMaxCode)) {
            fail<ValueError>("stacks: invalid layer code (material ", m, ", thickness ", t, ")");
        }
        out.push_back(code(Material(m), uint32_t(t)));
    }
    return at;
}

void Stacks::decodeUpTo(size_t s, std::vector<uint16_t>& out) const
{
    std::vector<uint16_t> prev;
    size_t at = mBlock[s / kBlock];
    for (size_t t = s - s % kBlock; t <= s; ++t) {
        at = decodeStack(mStream, at, mCount[t], prev, out);
        prev.swap(out);
    }
    out.swap(prev);
}

void Stacks::forEachStack(const std::function<void(size_t, const uint16_t*, size_t)>& visit) const
{
    std::vector<uint16_t> prev, cur;
    size_t at = 0;
    for (size_t s = 0; s < mCount.size(); ++s) {
        if (s % kBlock == 0) prev.clear();
        at = decodeStack(mStream, at, mCount[s], prev, cur);
        visit(s, cur.data(), cur.size());
        prev.swap(cur);
    }
}

Stacks Stacks::fromEncoding(const StackGeometry& geometry, std::vector<uint8_t> stream,
                            std::vector<uint8_t> counts)
{
    geometry.validate();
    if (counts.size() != geometry.count()) {
        fail<ValueError>("stacks: ", counts.size(), " stack counts for ", geometry.count(), " stacks");
    }
    Stacks r;
    r.mGeometry = geometry;
    r.mStream = std::move(stream);
    r.mCount = std::move(counts);
    // Decode everything once: block offsets, the code total, and the proof it is well formed.
    const size_t n = r.mCount.size();
    r.mBlock.resize((n + kBlock - 1) / kBlock);
    std::vector<uint16_t> prev, cur;
    size_t at = 0;
    for (size_t s = 0; s < n; ++s) {
        if (s % kBlock == 0) {
            r.mBlock[s / kBlock] = uint32_t(at);
            prev.clear();
        }
        at = decodeStack(r.mStream, at, r.mCount[s], prev, cur);
        // A block's first stack is coded in full, and air is never on top.
        if (!cur.empty() && codeMaterial(cur.back()) == Material::Air) fail<ValueError>("stacks: stack ", s, " ends with air");
        r.mCodes += cur.size();
        prev.swap(cur);
    }
    if (at != r.mStream.size()) fail<ValueError>("stacks: ", r.mStream.size() - at, " bytes left after the last stack");
    return r;
}

void Stacks::layers(int i, int j, std::vector<Layer>& out) const
{
    out.clear();
    std::vector<uint16_t> codes;
    decodeUpTo(mGeometry.index(i, j), codes);
    for (const uint16_t c : codes) {
        const Material m = codeMaterial(c);
        const uint32_t t = codeThickness(c);
        if (!out.empty() && out.back().material == m) out.back().thickness += t;
        else out.push_back(Layer{m, t});
    }
}

uint64_t Stacks::height(int i, int j) const
{
    std::vector<uint16_t> codes;
    decodeUpTo(mGeometry.index(i, j), codes);
    uint64_t h = 0;
    for (const uint16_t c : codes) h += codeThickness(c);
    return h;
}

uint64_t Stacks::volumeQuanta(Material m) const
{
    uint64_t v = 0;
    forEachStack([&](size_t, const uint16_t* codes, size_t n) {
        for (size_t k = 0; k < n; ++k) {
            if (codeMaterial(codes[k]) == m) v += codeThickness(codes[k]);
        }
    });
    return v;
}

// ---- skeleton -------------------------------------------------------------------------------

Skeleton::Skeleton(const Stacks& stacks, MaterialMask mask) : mGeometry(stacks.geometry()), mMask(mask)
{
    const auto& g = mGeometry;
    mFirst.resize(g.count() + 1);
    mFirst[0] = 0;
    stacks.forEachStack([&](size_t s, const uint16_t* codes, size_t n) {
        uint64_t z = 0;
        bool inside = false;
        for (size_t c = 0; c < n; ++c) {
            const bool in = (mask & maskOf(Stacks::codeMaterial(codes[c]))) != 0;
            const double at = g.z0 + double(z) * g.quantum;
            if (in && !inside) {
                mStart.push_back(at);
                mEnd.push_back(at);
            }
            z += Stacks::codeThickness(codes[c]);
            if (in) mEnd.back() = g.z0 + double(z) * g.quantum;
            inside = in;
        }
        mFirst[s + 1] = uint32_t(mStart.size());
    });
    mBefore.resize(mStart.size());
    for (size_t s = 0; s < g.count(); ++s) {
        double sum = 0;
        for (uint32_t k = mFirst[s]; k < mFirst[s + 1]; ++k) {
            mBefore[k] = sum;
            sum += mEnd[k] - mStart[k];
        }
    }
}

double Skeleton::top() const
{
    double t = mGeometry.z0;
    for (const double e : mEnd) t = std::max(t, e);
    return t;
}

double Skeleton::below(size_t s, double z) const
{
    const uint32_t a = mFirst[s], b = mFirst[s + 1];
    if (a == b || z <= mStart[a]) return 0.0;
    // The last interval starting below z.
    const uint32_t k = uint32_t(std::upper_bound(mStart.begin() + a, mStart.begin() + b, z) - mStart.begin()) - 1;
    return mBefore[k] + (std::min(z, mEnd[k]) - mStart[k]);
}

namespace {

// Every stack whose cell meets the square ‖q − p‖∞ < σ in xy, with the area they share:
// f(area, stack index).
template<typename F>
void forEachUnder(const StackGeometry& g, const Vec3d& p, double sigma, F&& f)
{
    const double xlo = p[0] - sigma, xhi = p[0] + sigma, ylo = p[1] - sigma, yhi = p[1] + sigma;
    const int i0 = std::max(0, int(std::floor((xlo - g.x0) / g.cell)));
    const int i1 = std::min(g.nx - 1, int(std::floor((xhi - g.x0) / g.cell)));
    const int j0 = std::max(0, int(std::floor((ylo - g.y0) / g.cell)));
    const int j1 = std::min(g.ny - 1, int(std::floor((yhi - g.y0) / g.cell)));
    for (int j = j0; j <= j1; ++j) {
        const double cy0 = g.y0 + j * g.cell;
        const double wy = std::min(yhi, cy0 + g.cell) - std::max(ylo, cy0);
        if (wy <= 0) continue;
        for (int i = i0; i <= i1; ++i) {
            const double cx0 = g.x0 + i * g.cell;
            const double wx = std::min(xhi, cx0 + g.cell) - std::max(xlo, cx0);
            if (wx > 0) f(wx * wy, g.index(i, j));
        }
    }
}

} // namespace

double Skeleton::volume(const Vec3d& p, double sigma) const
{
    double v = 0;
    forEachUnder(mGeometry, p, sigma, [&](double area, size_t s) { v += area * covered(s, p[2] - sigma, p[2] + sigma); });
    return v;
}

double Skeleton::featureSize(size_t s, double z) const
{
    const uint32_t a = mFirst[s], b = mFirst[s + 1];
    double scale = std::numeric_limits<double>::infinity();
    auto piece = [&](double lo, double hi) {
        const double off = z < lo ? lo - z : z > hi ? z - hi : 0.0;
        scale = std::min(scale, 0.5 * (hi - lo) + off);
    };
    for (uint32_t k = a; k < b; ++k) {
        piece(mStart[k], mEnd[k]);
        if (k > a) piece(mEnd[k - 1], mStart[k]);
    }
    return scale;
}

double Skeleton::interpolated(const Vec3d& p, double sigma, double reach) const
{
    // The stacks under the square and their weights (4 at σ = s/2; more for a wider square).
    struct Term { double w; size_t s; };
    Term local[16];
    std::vector<Term> more;
    size_t n = 0;
    double scale = std::numeric_limits<double>::infinity(), area = 0;
    forEachUnder(mGeometry, p, sigma, [&](double w, size_t s) {
        scale = std::min(scale, featureSize(s, p[2]));
        if (n < 16) local[n++] = Term{w, s};
        else more.push_back(Term{w, s});
        area += w;
    });
    // ρ − (length of skeleton within ρ of z): clamp(vertical distance, ±ρ) where one boundary
    // is within ρ, the box's erosion of what is thinner.
    const double rho = std::min(reach, std::max(sigma, scale)), z = p[2];
    const double full = 4.0 * sigma * sigma;
    double sum = std::max(0.0, full - area) * rho; // outside the grid: air
    for (size_t k = 0; k < n; ++k) sum += local[k].w * (rho - covered(local[k].s, z - rho, z + rho));
    for (const Term& t : more) sum += t.w * (rho - covered(t.s, z - rho, z + rho));
    return sum / full;
}

} // namespace arches
} // namespace rockvdb
