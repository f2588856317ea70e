// SPDX-License-Identifier: Apache-2.0
// Fractal rocks on a ground: grounds, the candidate sequence and the footprint test.
#include "Scatter.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Random.h>

#include <openvdb/tools/Interpolation.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <unordered_map>

namespace rockvdb {
namespace fractal {

namespace {

enum ScatterStream : uint64_t { kCandidate = 0x5ca7, kRockSeed = 0x5ca8, kDensity = 0x5ca9 };

class PlaneGround : public Ground
{
public:
    double height(double, double) const override { return 0.0; }
};

// Heightfield triangulated along each cell's (i, j)–(i+1, j+1) diagonal (as heightfieldField);
// outside the footprint, the nearest edge sample's height.
class HeightfieldGround : public Ground
{
public:
    explicit HeightfieldGround(std::shared_ptr<const Heightfield> hf) : mHf(std::move(hf)) {}
    double height(double x, double y) const override
    {
        const Heightfield& h = *mHf;
        const double u = std::min(std::max(x / h.cellSize, 0.0), double(h.nx - 1));
        const double v = std::min(std::max(y / h.cellSize, 0.0), double(h.ny - 1));
        const int i = std::min(int(u), h.nx - 2), j = std::min(int(v), h.ny - 2);
        const double fx = u - i, fy = v - j;
        const double h00 = h.at(i, j), h10 = h.at(i + 1, j), h01 = h.at(i, j + 1),
                     h11 = h.at(i + 1, j + 1);
        if (fx >= fy) return h00 + fx * (h10 - h00) + fy * (h11 - h10);
        return h00 + fy * (h01 - h00) + fx * (h11 - h01);
    }
    std::optional<std::array<double, 4>> bounds() const override
    {
        return std::array<double, 4>{0.0, 0.0, mHf->width(), mHf->depth()};
    }

private:
    std::shared_ptr<const Heightfield> mHf;
};

// A level set's top surface, tabulated per voxel column and interpolated bilinearly.
class LevelSetGround : public Ground
{
public:
    explicit LevelSetGround(const openvdb::FloatGrid& grid)
    {
        const openvdb::CoordBBox box = grid.evalActiveVoxelBoundingBox();
        if (box.empty()) fail<ValueError>("fractal: the ground level set is empty");
        mDx = grid.voxelSize()[0];
        mLo = box.min();
        mNx = box.dim()[0];
        mNy = box.dim()[1];
        if (double(mNx) * mNy > 1e8) fail<ValueError>("fractal: the ground level set is too wide (", mNx, " x ", mNy, " columns)");
        mH.resize(size_t(mNx) * size_t(mNy));
        const int zTop = box.max()[2] + 1, zBottom = box.min()[2] - 1;
        tbb::parallel_for(0, mNy, [&](int jj) {
            auto acc = grid.getConstAccessor();
            for (int ii = 0; ii < mNx; ++ii) {
                const int i = mLo[0] + ii, j = mLo[1] + jj;
                double h = zBottom * mDx;
                float above = acc.getValue(openvdb::Coord(i, j, zTop));
                for (int k = zTop - 1; k >= zBottom; --k) {
                    const float v = acc.getValue(openvdb::Coord(i, j, k));
                    if (above > 0 && v <= 0) {
                        // Linear zero crossing between k and k + 1 (voxel centres at k·dx).
                        const double t = above / double(above - v);
                        h = (k + 1 - t) * mDx;
                        break;
                    }
                    above = v;
                }
                mH[size_t(jj) * size_t(mNx) + size_t(ii)] = h;
            }
        });
    }
    double height(double x, double y) const override
    {
        const double u = std::min(std::max(x / mDx - mLo[0], 0.0), double(mNx - 1));
        const double v = std::min(std::max(y / mDx - mLo[1], 0.0), double(mNy - 1));
        const int i = std::min(int(u), std::max(0, mNx - 2)), j = std::min(int(v), std::max(0, mNy - 2));
        const int i1 = std::min(i + 1, mNx - 1), j1 = std::min(j + 1, mNy - 1);
        const double fx = u - i, fy = v - j;
        auto at = [&](int a, int b) { return mH[size_t(b) * size_t(mNx) + size_t(a)]; };
        return (at(i, j) * (1 - fx) + at(i1, j) * fx) * (1 - fy) + (at(i, j1) * (1 - fx) + at(i1, j1) * fx) * fy;
    }
    std::optional<std::array<double, 4>> bounds() const override
    {
        return std::array<double, 4>{mLo[0] * mDx, mLo[1] * mDx, (mLo[0] + mNx - 1) * mDx,
                                     (mLo[1] + mNy - 1) * mDx};
    }

private:
    double mDx = 1;
    openvdb::Coord mLo;
    int mNx = 0, mNy = 0;
    std::vector<double> mH;
};

} // namespace

std::shared_ptr<const Ground> planeGround() { return std::make_shared<PlaneGround>(); }

std::shared_ptr<const Ground> heightfieldGround(std::shared_ptr<const Heightfield> hf)
{
    if (!hf || hf->nx < 2 || hf->ny < 2) fail<ValueError>("fractal: the ground heightfield needs at least 2 x 2 samples");
    return std::make_shared<HeightfieldGround>(std::move(hf));
}

std::shared_ptr<const Ground> levelSetGround(const openvdb::FloatGrid& grid)
{
    return std::make_shared<LevelSetGround>(grid);
}

double displacementBound(const RockShape& shape)
{
    // Σ_l roughness · ℓ0 · (ℓ_l/ℓ0)^H_min, × 1.25 for the damping patches (their interior
    // weights on the displaced midpoints sum to at most 1.25).
    const double l0 = 1.0 / std::sin(2.0 * M_PI / 5.0);
    const double k = shape.method == Method::Midpoint ? 2.0 : 4.0;
    const double h = std::min(shape.hUp, shape.hDown);
    double d = 0;
    for (int l = 0; l < shape.levels; ++l) d += shape.roughness * l0 * std::pow(k, -l * h);
    return 1.25 * d;
}

std::vector<Placed> placeRocks(const ScatterSettings& s, ScatterStats& stats, Task& task)
{
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    stats.asked = size_t(s.count);
    const double bound = 1.0 + displacementBound(s.shape);
    const double maxRadius = 0.5 * std::max({s.size[0], s.size[1], s.size[2]}) * bound;
    noise::Fbm fbm;
    fbm.frequency = 1.0 / s.densityScale;
    fbm.octaves = s.densityOctaves;
    const double norm = 1.0 / fbm.amplitudeSum();
    const uint64_t seed = s.shape.seed;
    // Footprint discs on a hash grid of cells 2·maxRadius wide.
    const double cell = 2.0 * maxRadius;
    std::unordered_map<uint64_t, std::vector<uint32_t>> grid;
    auto key = [](int64_t i, int64_t j) { return uint64_t(i) * 0x9e3779b97f4a7c15ull ^ uint64_t(j); };
    std::vector<Placed> out;
    const uint64_t maxCandidates = uint64_t(s.count) * uint64_t(s.attempts);
    const double w = s.area[2] - s.area[0], d = s.area[3] - s.area[1];
    for (uint64_t c = 0; c < maxCandidates && out.size() < size_t(s.count); ++c) {
        if (c % 4096 == 0) task.step(double(out.size()) / double(s.count));
        ++stats.candidates;
        const double x = s.area[0] + w * random::uniform(seed, kCandidate, 8 * c);
        const double y = s.area[1] + d * random::uniform(seed, kCandidate, 8 * c + 1);
        if (s.densityContrast > 0) {
            const double f = noise::fbm2(random::hash(seed, kDensity, 0), fbm, float(x), float(y)) * norm;
            const double density = std::pow(std::min(1.0, std::max(0.0, 0.5 * (1.0 + 1.5 * f))), s.densityContrast);
            if (random::uniform(seed, kCandidate, 8 * c + 2) >= density) {
                ++stats.rejectedDensity;
                continue;
            }
        }
        Placed r;
        const double scale = 1.0 - s.sizeJitter * random::uniform(seed, kCandidate, 8 * c + 3);
        r.extent = Vec3d(0.5 * s.size[0] * scale,
                         0.5 * s.size[1] * scale * (1.0 - s.aspectJitter * random::uniform(seed, kCandidate, 8 * c + 4)),
                         0.5 * s.size[2] * scale * (1.0 - s.aspectJitter * random::uniform(seed, kCandidate, 8 * c + 5)));
        r.radius = std::max({r.extent[0], r.extent[1], r.extent[2]}) * bound;
        // Discs: each rock lies inside the vertical cylinder of its radius, so disjoint
        // discs mean disjoint rocks whatever their heights.
        const int64_t ci = int64_t(std::floor(x / cell)), cj = int64_t(std::floor(y / cell));
        bool free = true;
        for (int64_t a = ci - 1; a <= ci + 1 && free; ++a)
            for (int64_t b = cj - 1; b <= cj + 1 && free; ++b) {
                auto it = grid.find(key(a, b));
                if (it == grid.end()) continue;
                for (uint32_t o : it->second) {
                    const Placed& q = out[o];
                    const double dx = q.position[0] - x, dy = q.position[1] - y;
                    if (dx * dx + dy * dy < (q.radius + r.radius) * (q.radius + r.radius)) {
                        free = false;
                        break;
                    }
                }
            }
        if (!free) {
            ++stats.rejectedOverlap;
            continue;
        }
        r.position = Vec3d(x, y, 0);
        r.seed = random::hash(seed, kRockSeed, c);
        r.rotation = randomOrientation(r.seed, s.tilt);
        grid[key(ci, cj)].push_back(uint32_t(out.size()));
        out.push_back(r);
    }
    stats.placed = out.size();
    stats.placeSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
    return out;
}

} // namespace fractal
} // namespace rockvdb
