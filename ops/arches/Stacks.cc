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
    Stacks r;
    r.mGeometry = geometry;
    // Each row encoded alone, then concatenated in row order.
    std::vector<std::vector<uint16_t>> rows(size_t(geometry.ny));
    std::vector<std::vector<uint32_t>> counts(size_t(geometry.ny));
    parallelFor(task, size_t(geometry.ny), 1, [&](size_t j) {
        std::vector<Layer> layers;
        auto& codes = rows[j];
        auto& count = counts[j];
        count.resize(size_t(geometry.nx));
        for (int i = 0; i < geometry.nx; ++i) {
            layers.clear();
            column(i, int(j), layers);
            const size_t before = codes.size();
            Material last = Material::Air;
            uint32_t pending = 0;
            auto flush = [&] {
                while (pending > 0) {
                    const uint32_t t = std::min(pending, kMaxCode);
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
                fail<ValueError>("stacks: stack (", i, ", ", j, ") needs ", codes.size() - before,
                                 " layer codes, more than the 255 a stack holds; use a larger thickness quantum");
            }
            count[size_t(i)] = uint32_t(codes.size() - before);
        }
    });
    size_t total = 0;
    for (const auto& row : rows) total += row.size();
    if (total > std::numeric_limits<uint32_t>::max()) {
        fail<ValueError>("stacks: ", total, " layer codes exceed the 32-bit offsets");
    }
    r.mCode.reserve(total);
    r.mCount.reserve(geometry.count());
    for (size_t j = 0; j < rows.size(); ++j) {
        r.mCode.insert(r.mCode.end(), rows[j].begin(), rows[j].end());
        for (const uint32_t c : counts[j]) r.mCount.push_back(uint8_t(c));
        std::vector<uint16_t>().swap(rows[j]);
    }
    r.index();
    return r;
}

void Stacks::index()
{
    mBlock.assign((mCount.size() + kBlockMask) >> kBlockBits, 0);
    size_t at = 0;
    for (size_t s = 0; s < mCount.size(); ++s) {
        if ((s & kBlockMask) == 0) mBlock[s >> kBlockBits] = uint32_t(at);
        at += mCount[s];
    }
}

Stacks Stacks::fromEncoding(const StackGeometry& geometry, std::vector<uint16_t> codes,
                            std::vector<uint8_t> counts)
{
    geometry.validate();
    size_t total = 0;
    for (const uint8_t c : counts) total += c;
    if (counts.size() != geometry.count() || total != codes.size()) {
        fail<ValueError>("stacks: ", counts.size(), " stack counts holding ", total, " codes do not match ",
                         geometry.count(), " stacks of ", codes.size(), " codes");
    }
    for (const uint16_t c : codes) {
        if (unsigned(codeMaterial(c)) >= unsigned(kMaterialCount) || codeThickness(c) == 0) {
            fail<ValueError>("stacks: invalid layer code ", c);
        }
    }
    Stacks r;
    r.mGeometry = geometry;
    r.mCode = std::move(codes);
    r.mCount = std::move(counts);
    r.index();
    return r;
}

void Stacks::layers(int i, int j, std::vector<Layer>& out) const
{
    out.clear();
    const size_t s = mGeometry.index(i, j), b = begin(s);
    for (size_t c = b; c < b + mCount[s]; ++c) {
        const Material m = codeMaterial(mCode[c]);
        const uint32_t t = codeThickness(mCode[c]);
        if (!out.empty() && out.back().material == m) out.back().thickness += t;
        else out.push_back(Layer{m, t});
    }
}

uint64_t Stacks::height(int i, int j) const
{
    const size_t s = mGeometry.index(i, j), b = begin(s);
    uint64_t h = 0;
    for (size_t c = b; c < b + mCount[s]; ++c) h += codeThickness(mCode[c]);
    return h;
}

uint64_t Stacks::volumeQuanta(Material m) const
{
    uint64_t v = 0;
    for (const uint16_t c : mCode) {
        if (codeMaterial(c) == m) v += codeThickness(c);
    }
    return v;
}

// ---- skeleton -------------------------------------------------------------------------------

Skeleton::Skeleton(const Stacks& stacks, MaterialMask mask) : mGeometry(stacks.geometry()), mMask(mask)
{
    const auto& g = mGeometry;
    const auto& codes = stacks.codes();
    const auto& counts = stacks.counts();
    mFirst.resize(g.count() + 1);
    mFirst[0] = 0;
    size_t next = 0;
    for (size_t s = 0; s < g.count(); ++s) {
        uint64_t z = 0;
        bool inside = false;
        const size_t b = next;
        next += counts[s];
        for (size_t c = b; c < next; ++c) {
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
    }
    mBefore.resize(mStart.size());
    for (size_t s = 0; s < g.count(); ++s) {
        double sum = 0;
        for (uint32_t k = mFirst[s]; k < mFirst[s + 1]; ++k) {
            mBefore[k] = sum;
            sum += mEnd[k] - mStart[k];
        }
    }
}

double Skeleton::below(size_t s, double z) const
{
    const uint32_t a = mFirst[s], b = mFirst[s + 1];
    if (a == b || z <= mStart[a]) return 0.0;
    // The last interval starting below z.
    const uint32_t k = uint32_t(std::upper_bound(mStart.begin() + a, mStart.begin() + b, z) - mStart.begin()) - 1;
    return mBefore[k] + (std::min(z, mEnd[k]) - mStart[k]);
}

double Skeleton::volume(const Vec3d& p, double sigma) const
{
    const auto& g = mGeometry;
    const double xlo = p[0] - sigma, xhi = p[0] + sigma, ylo = p[1] - sigma, yhi = p[1] + sigma;
    // Stacks whose cells meet the cube's footprint.
    const int i0 = std::max(0, int(std::floor((xlo - g.x0) / g.cell)));
    const int i1 = std::min(g.nx - 1, int(std::floor((xhi - g.x0) / g.cell)));
    const int j0 = std::max(0, int(std::floor((ylo - g.y0) / g.cell)));
    const int j1 = std::min(g.ny - 1, int(std::floor((yhi - g.y0) / g.cell)));
    double v = 0;
    for (int j = j0; j <= j1; ++j) {
        const double cy0 = g.y0 + j * g.cell;
        const double wy = std::min(yhi, cy0 + g.cell) - std::max(ylo, cy0);
        if (wy <= 0) continue;
        for (int i = i0; i <= i1; ++i) {
            const double cx0 = g.x0 + i * g.cell;
            const double wx = std::min(xhi, cx0 + g.cell) - std::max(xlo, cx0);
            if (wx <= 0) continue;
            v += wx * wy * covered(g.index(i, j), p[2] - sigma, p[2] + sigma);
        }
    }
    return v;
}

} // namespace arches
} // namespace rockvdb
