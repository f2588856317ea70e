// SPDX-License-Identifier: Apache-2.0
#include "Chunks.h"

#include <rockvdb/core/Error.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <limits>

namespace rockvdb {

using openvdb::Coord;
using openvdb::CoordBBox;

namespace {

constexpr int kMaxDim = 4096;         // chunks along one axis
constexpr int kMaxCount = 1 << 20;    // chunks of one bake

// Non-negative decimal integer, the whole text (no sign, no spaces); -1 otherwise.
long long parseCount(const std::string& s)
{
    if (s.empty() || s.size() > 9) return -1;
    long long v = 0;
    for (char c : s) {
        if (!std::isdigit(static_cast<unsigned char>(c))) return -1;
        v = v * 10 + (c - '0');
    }
    return v;
}

int floorTo(long long v, int align)
{
    return int((v >= 0 ? v : v - (align - 1)) / align * align);
}

std::atomic<double> gPlanBudget{-1.0}; // < 0: no plan requested

} // namespace

ChunkSpec ChunkSpec::parse(const std::string& chunks, const std::string& chunk, const char* op)
{
    ChunkSpec s;
    if (!chunks.empty()) {
        std::array<long long, 3> d{{-1, -1, -1}};
        size_t start = 0;
        for (int a = 0; a < 3; ++a) {
            const size_t end = a < 2 ? chunks.find('x', start) : chunks.size();
            if (end == std::string::npos) break;
            d[a] = parseCount(chunks.substr(start, end - start));
            start = end + 1;
        }
        for (int a = 0; a < 3; ++a) {
            if (d[a] < 1 || d[a] > kMaxDim) {
                fail<ValueError>(op, ": chunks must be AxBxC, each in [1, ", kMaxDim,
                                 "] (e.g. 4x4x1) (got '", chunks, "')");
            }
            s.dims[a] = int(d[a]);
        }
        if (double(s.dims[0]) * s.dims[1] * s.dims[2] > kMaxCount) {
            fail<ValueError>(op, ": chunks '", chunks, "' makes more than ", kMaxCount, " chunks");
        }
        s.dimsGiven = true;
    }
    if (!chunk.empty()) {
        const size_t slash = chunk.find('/');
        const long long i = slash == std::string::npos ? -1 : parseCount(chunk.substr(0, slash));
        const long long n = slash == std::string::npos ? -1 : parseCount(chunk.substr(slash + 1));
        if (i < 0 || n < 1 || n > kMaxCount || i >= n) {
            fail<ValueError>(op, ": chunk must be i/N with 0 <= i < N <= ", kMaxCount,
                             " (chunks are numbered from 0) (got '", chunk, "')");
        }
        s.index = int(i);
        s.count = int(n);
        if (s.dimsGiven && s.count != s.dims[0] * s.dims[1] * s.dims[2]) {
            fail<ValueError>(op, ": chunk '", chunk, "' counts ", n, " chunks but chunks '",
                             chunks, "' makes ", s.dims[0] * s.dims[1] * s.dims[2]);
        }
    }
    return s;
}

std::array<int, 3> autoChunkDims(const CoordBBox& whole, int count, ChunkGrid grid)
{
    const Coord ext = whole.empty() ? Coord(1) : whole.extents();
    std::array<int, 3> best{{count, 1, 1}};
    double bestSide = std::numeric_limits<double>::infinity(), bestArea = bestSide;
    for (int a = 1; a <= count; ++a) {
        if (count % a) continue;
        for (int b = 1; b <= count / a; ++b) {
            if ((count / a) % b) continue;
            const int c = count / a / b;
            if (c > 1 && !grid.splitZ) continue;
            const double sx = double(ext[0]) / a, sy = double(ext[1]) / b, sz = double(ext[2]) / c;
            const double side = std::max({sx, sy, sz});
            const double area = sx * sy + sy * sz + sz * sx;
            // Smallest largest side, then least surface (the chunks' shared band), then the
            // first found (a pure function of the box and the count).
            if (side < bestSide - 1e-9 || (side < bestSide + 1e-9 && area < bestArea - 1e-9)) {
                best = {{a, b, c}};
                bestSide = side;
                bestArea = area;
            }
        }
    }
    if (!grid.splitZ && best[2] > 1) {
        fail<ValueError>("chunk: ", count, " chunks cannot be cut in x and y alone");
    }
    return best;
}

std::array<int, 3> chunkDims(const ChunkSpec& spec, const CoordBBox& whole, ChunkGrid grid)
{
    if (spec.dimsGiven) return spec.dims;
    if (spec.count > 0) return autoChunkDims(whole, spec.count, grid);
    return {{1, 1, 1}};
}

CoordBBox chunkBox(const CoordBBox& whole, const std::array<int, 3>& dims, int index, ChunkGrid grid)
{
    if (whole.empty()) return whole;
    const int c[3] = {index % dims[0], (index / dims[0]) % dims[1], index / (dims[0] * dims[1])};
    Coord lo, hi;
    for (int a = 0; a < 3; ++a) {
        const long long min = whole.min()[a], len = (long long)whole.max()[a] - min + 1;
        auto cut = [&](int k) -> long long {
            if (k <= 0) return min;
            if (k >= dims[a]) return min + len;
            return floorTo(min + len * k / dims[a], grid.align);
        };
        lo[a] = int(std::max(cut(c[a]), min));
        hi[a] = int(std::min(cut(c[a] + 1) - 1, min + len - 1));
    }
    return CoordBBox(lo, hi);
}

std::string chunkDimsText(const std::array<int, 3>& dims)
{
    return std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + "x" + std::to_string(dims[2]);
}

void requestPlan(double budgetBytes) { gPlanBudget.store(std::max(0.0, budgetBytes)); }

bool planRequested() { return gPlanBudget.load() >= 0; }

void reportPlanIfRequested(const std::string& op, const CoordBBox& whole, double voxelSize,
                           const ChunkSpec& spec,
                           const std::function<double(const CoordBBox&)>& estimate,
                           ChunkGrid grid)
{
    const double budget = gPlanBudget.load();
    if (budget < 0) return;
    auto largest = [&](const std::array<int, 3>& dims) {
        double m = 0;
        const int n = dims[0] * dims[1] * dims[2];
        for (int i = 0; i < n; ++i) {
            const CoordBBox b = chunkBox(whole, dims, i, grid);
            if (!b.empty()) m = std::max(m, estimate(b));
        }
        return m;
    };
    std::array<int, 3> dims = spec.dimsGiven || spec.count > 0 ? chunkDims(spec, whole, grid)
                                                                : std::array<int, 3>{{1, 1, 1}};
    double chunkBytes = whole.empty() ? 0.0 : largest(dims);
    if (budget > 0 && !spec.dimsGiven && !whole.empty()) {
        // Halve the longest chunk side until the largest chunk fits (every chunk keeps at
        // least two leaves along the axis it is cut on).
        const Coord ext = whole.extents();
        while (chunkBytes > budget) {
            int axis = -1;
            double side = 0;
            for (int a = 0; a < (grid.splitZ ? 3 : 2); ++a) {
                const double s = double(ext[a]) / dims[a];
                if (s >= 4 * grid.align && s > side) { side = s; axis = a; }
            }
            if (axis < 0 || double(dims[0]) * dims[1] * dims[2] * 2 > kMaxCount) {
                fail<ValueError>(op, ": no split into chunks of at least ", 2 * grid.align,
                                 " voxels a side fits ",
                                 "the chunk memory budget (", budget / 1e9, " GB; the smallest "
                                 "chunks need ", chunkBytes / 1e9, " GB)");
            }
            dims[axis] *= 2;
            chunkBytes = largest(dims);
        }
    }
    const int count = dims[0] * dims[1] * dims[2];
    nlohmann::json box = nullptr, voxels = nullptr;
    if (!whole.empty()) {
        box = {{whole.min()[0], whole.min()[1], whole.min()[2]},
               {whole.max()[0], whole.max()[1], whole.max()[2]}};
        const Coord e = whole.extents();
        voxels = {e[0], e[1], e[2]};
    }
    throw PlanReady({{"op", op},
                     {"voxel_size", voxelSize},
                     {"box", box},
                     {"voxels", voxels},
                     {"bytes", whole.empty() ? 0.0 : estimate(whole)},
                     {"chunks", chunkDimsText(dims)},
                     {"count", count},
                     {"chunk_bytes", chunkBytes},
                     {"budget_bytes", budget}});
}

} // namespace rockvdb
