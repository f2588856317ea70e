// SPDX-License-Identifier: Apache-2.0
#include "Sampling.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>

#include <algorithm>
#include <cmath>

namespace rockvdb {

namespace {

double wrap(double v, double size)
{
    v = std::fmod(v, size);
    if (v < 0) v += size;
    return v >= size ? 0.0 : v;
}

int wrapIndex(int i, int n) { return ((i % n) + n) % n; }

// A cubic grid of n³ cells over the periodic cube; each cell holds point indices.
struct PeriodicGrid
{
    int n;
    double cell;
    std::vector<std::vector<int>> cells;

    PeriodicGrid(double size, double minCell)
        : n(std::max(1, int(std::floor(size / minCell)))), cell(size / double(n)),
          cells(size_t(n) * size_t(n) * size_t(n)) {}

    int coord(double v) const { return std::min(n - 1, int(v / cell)); }
    std::vector<int>& at(int i, int j, int k)
    {
        return cells[(size_t(wrapIndex(i, n)) * size_t(n) + size_t(wrapIndex(j, n))) *
                         size_t(n) + size_t(wrapIndex(k, n))];
    }
};

} // namespace

Vec3d periodicDelta(const Vec3d& a, const Vec3d& b, double size)
{
    Vec3d d = b - a;
    for (int c = 0; c < 3; ++c) d[c] -= size * std::round(d[c] / size);
    return d;
}

std::vector<Vec3d> poissonPeriodic(double size, double radius, uint64_t seed, uint64_t stream,
                                   int attempts)
{
    require(std::isfinite(size) && size > 0, "poisson", "tile size", "> 0", size);
    require(std::isfinite(radius) && radius > 0 && radius < size / 2, "poisson", "radius",
            "in (0, tile size / 2)", radius);
    require(attempts >= 1 && attempts <= 1000, "poisson", "attempts", "in [1, 1000]", attempts);
    // Cells of side >= r/√3 hold at most one point, so a grid of point indices suffices.
    const double minCell = radius / std::sqrt(3.0);
    const int n = std::max(1, int(std::floor(size / minCell)));
    require(double(n) * n * n <= 64e6, "poisson", "tile size / radius", "<= ~400 (memory)",
            size / radius);
    const double cell = size / double(n);
    std::vector<int> grid(size_t(n) * size_t(n) * size_t(n), -1);
    auto slot = [&](int i, int j, int k) -> int& {
        return grid[(size_t(wrapIndex(i, n)) * size_t(n) + size_t(wrapIndex(j, n))) * size_t(n) +
                    size_t(wrapIndex(k, n))];
    };
    const int reachCells = std::min(3, int(std::ceil(radius / cell)));
    const double r2 = radius * radius;
    std::vector<Vec3d> points;
    std::vector<int> active;
    uint64_t counter = 0;
    auto rnd = [&]() { return random::uniform(seed, stream, counter++); };

    // Neighbour cells nearest first (a rejected candidate, the common case, exits early),
    // leaving out those farther than r; each is visited with its wrap offset, so distances
    // are plain differences.
    std::vector<std::array<int, 3>> order;
    {
        const int span = 2 * reachCells + 1;
        std::vector<std::pair<double, std::array<int, 3>>> byDist;
        for (int i = 0; i < span; ++i)
            for (int j = 0; j < span; ++j)
                for (int k = 0; k < span; ++k) {
                    double d2 = 0;
                    for (int o : {i, j, k}) {
                        const double g = std::max(0, std::abs(o - reachCells) - 1) * cell;
                        d2 += g * g;
                    }
                    if (d2 < r2) byDist.push_back({d2, {i, j, k}});
                }
        std::stable_sort(byDist.begin(), byDist.end(),
                         [](const auto& a, const auto& b) { return a.first < b.first; });
        for (const auto& e : byDist) order.push_back(e.second);
    }
    auto fits = [&](const Vec3d& p) {
        const int c[3] = {std::min(n - 1, int(p[0] / cell)), std::min(n - 1, int(p[1] / cell)),
                          std::min(n - 1, int(p[2] / cell))};
        int idx[3][8];
        double off[3][8];
        const int span = 2 * reachCells + 1;
        for (int a = 0; a < 3; ++a) {
            for (int t = 0; t < span; ++t) {
                const int raw = c[a] - reachCells + t;
                const int w = wrapIndex(raw, n);
                idx[a][t] = w;
                off[a][t] = double((raw - w) / n) * size; // image shift of that cell
            }
        }
        for (const auto& o3 : order) {
            const int i = o3[0], j = o3[1], k = o3[2];
            const int q = grid[(size_t(idx[0][i]) * size_t(n) + size_t(idx[1][j])) * size_t(n) +
                               size_t(idx[2][k])];
            if (q < 0) continue;
            const Vec3d& o = points[size_t(q)];
            const double dx = o[0] + off[0][i] - p[0], dy = o[1] + off[1][j] - p[1],
                         dz = o[2] + off[2][k] - p[2];
            if (dx * dx + dy * dy + dz * dz < r2) return false;
        }
        return true;
    };
    auto add = [&](const Vec3d& p) {
        slot(std::min(n - 1, int(p[0] / cell)), std::min(n - 1, int(p[1] / cell)),
             std::min(n - 1, int(p[2] / cell))) = int(points.size());
        active.push_back(int(points.size()));
        points.push_back(p);
    };

    add(Vec3d(rnd() * size, rnd() * size, rnd() * size));
    while (!active.empty()) {
        const size_t pick = std::min(active.size() - 1, size_t(rnd() * double(active.size())));
        const Vec3d centre = points[size_t(active[pick])];
        bool placed = false;
        for (int a = 0; a < attempts; ++a) {
            // Uniform in the spherical shell [r, 2r] (uniform in volume).
            const double z = 2.0 * rnd() - 1.0, phi = 2.0 * M_PI * rnd();
            const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
            const double rr = radius * std::cbrt(1.0 + 7.0 * rnd());
            const Vec3d p(wrap(centre[0] + rr * s * std::cos(phi), size),
                          wrap(centre[1] + rr * s * std::sin(phi), size),
                          wrap(centre[2] + rr * z, size));
            if (fits(p)) {
                add(p);
                placed = true;
                break;
            }
        }
        if (!placed) {
            active[pick] = active.back();
            active.pop_back();
        }
    }
    return points;
}

std::vector<Vec3d> poissonBox(const Vec3d& lo, const Vec3d& hi, double radius, uint64_t seed,
                              uint64_t stream, int attempts)
{
    require(std::isfinite(radius) && radius > 0, "poisson", "radius", "> 0", radius);
    require(attempts >= 1 && attempts <= 1000, "poisson", "attempts", "in [1, 1000]", attempts);
    const double cell = radius / std::sqrt(3.0); // a cell holds at most one point
    int n[3];
    double cells = 1;
    for (int a = 0; a < 3; ++a) {
        require(std::isfinite(lo[a]) && std::isfinite(hi[a]) && hi[a] >= lo[a], "poisson", "box extent",
                "finite, hi >= lo", hi[a] - lo[a]);
        n[a] = std::max(1, int(std::ceil((hi[a] - lo[a]) / cell)));
        cells *= double(n[a]);
    }
    require(cells <= 64e6, "poisson", "box cells", "<= 64e6 (memory)", cells);
    std::vector<int> grid(size_t(cells), -1);
    auto index = [&](int i, int j, int k) { return (size_t(i) * size_t(n[1]) + size_t(j)) * size_t(n[2]) + size_t(k); };
    auto coord = [&](const Vec3d& p, int a) { return std::clamp(int((p[a] - lo[a]) / cell), 0, n[a] - 1); };
    const double r2 = radius * radius;
    std::vector<Vec3d> points;
    std::vector<int> active;
    uint64_t counter = 0;
    auto rnd = [&]() { return random::uniform(seed, stream, counter++); };
    // Neighbour cells that may hold a point closer than r, nearest first (a rejected
    // candidate, the common case, exits early).
    std::vector<std::array<int, 3>> order;
    {
        std::vector<std::pair<int, std::array<int, 3>>> byDist;
        for (int i = -2; i <= 2; ++i)
            for (int j = -2; j <= 2; ++j)
                for (int k = -2; k <= 2; ++k) {
                    int gap2 = 0; // squared gap in cells between the two cells
                    for (int o : {i, j, k}) gap2 += std::max(0, std::abs(o) - 1) * std::max(0, std::abs(o) - 1);
                    if (gap2 < 3) byDist.push_back({i * i + j * j + k * k, {i, j, k}}); // gap < r = √3 cells
                }
        std::stable_sort(byDist.begin(), byDist.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        for (const auto& e : byDist) order.push_back(e.second);
    }
    auto fits = [&](const Vec3d& p) {
        for (int a = 0; a < 3; ++a) {
            if (!(p[a] >= lo[a] && p[a] <= hi[a])) return false;
        }
        const int c[3] = {coord(p, 0), coord(p, 1), coord(p, 2)};
        for (const auto& o : order) {
            const int i = c[0] + o[0], j = c[1] + o[1], k = c[2] + o[2];
            if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) continue;
            const int q = grid[index(i, j, k)];
            if (q >= 0 && (points[size_t(q)] - p).lengthSqr() < r2) return false;
        }
        return true;
    };
    auto add = [&](const Vec3d& p) {
        grid[index(coord(p, 0), coord(p, 1), coord(p, 2))] = int(points.size());
        active.push_back(int(points.size()));
        points.push_back(p);
    };
    {
        const double u = rnd(), v = rnd(), t = rnd(); // in this order (not argument order)
        add(Vec3d(lo[0] + u * (hi[0] - lo[0]), lo[1] + v * (hi[1] - lo[1]), lo[2] + t * (hi[2] - lo[2])));
    }
    while (!active.empty()) {
        const size_t pick = std::min(active.size() - 1, size_t(rnd() * double(active.size())));
        const Vec3d centre = points[size_t(active[pick])];
        bool placed = false;
        for (int a = 0; a < attempts && !placed; ++a) {
            // Uniform in the spherical shell [r, 2r] (uniform in volume).
            const double z = 2.0 * rnd() - 1.0, phi = 2.0 * M_PI * rnd();
            const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
            const double rr = radius * std::cbrt(1.0 + 7.0 * rnd());
            const Vec3d p(centre[0] + rr * s * std::cos(phi), centre[1] + rr * s * std::sin(phi),
                          centre[2] + rr * z);
            if (fits(p)) {
                add(p);
                placed = true;
            }
        }
        if (!placed) {
            active[pick] = active.back();
            active.pop_back();
        }
    }
    return points;
}

std::vector<Vec3d> dartsPeriodic(double size, double spacing, int count, uint64_t seed,
                                 uint64_t stream)
{
    require(std::isfinite(size) && size > 0, "darts", "tile size", "> 0", size);
    require(std::isfinite(spacing) && spacing >= 0 && spacing < size / 2, "darts", "spacing",
            "in [0, tile size / 2)", spacing);
    require(count >= 0 && count <= 100000, "darts", "count", "in [0, 100000]", count);
    std::vector<Vec3d> points;
    uint64_t counter = 0;
    const double s2 = spacing * spacing;
    int rejected = 0;
    while (int(points.size()) < count && rejected < 200 * std::max(count, 1)) {
        const Vec3d p(random::uniform(seed, stream, counter) * size,
                      random::uniform(seed, stream, counter + 1) * size,
                      random::uniform(seed, stream, counter + 2) * size);
        counter += 3;
        bool ok = true;
        for (const auto& q : points) {
            if (periodicDelta(p, q, size).lengthSqr() < s2) { ok = false; break; }
        }
        if (ok) points.push_back(p); else ++rejected;
    }
    return points;
}

std::vector<PeriodicEdge> neighbourGraph(const std::vector<Vec3d>& points, double size,
                                         double radius)
{
    require(std::isfinite(radius) && radius > 0 && radius < size / 2, "graph",
            "neighbour radius", "in (0, tile size / 2)", radius);
    PeriodicGrid grid(size, radius);
    for (size_t i = 0; i < points.size(); ++i) {
        const Vec3d& p = points[i];
        grid.at(grid.coord(p[0]), grid.coord(p[1]), grid.coord(p[2])).push_back(int(i));
    }
    const double r2 = radius * radius;
    std::vector<PeriodicEdge> edges;
    auto consider = [&](size_t a, int b) {
        const Vec3d& p = points[a];
        const Vec3d d = periodicDelta(p, points[size_t(b)], size);
        if (d.lengthSqr() >= r2) return;
        const Vec3d raw = points[size_t(b)] - p;
        PeriodicEdge e{int(a), b, {0, 0, 0}};
        for (int c = 0; c < 3; ++c) {
            e.shift[size_t(c)] = int8_t(std::lround((d[c] - raw[c]) / size));
        }
        edges.push_back(e);
    };
    if (grid.n < 3) {
        // Fewer than 3 cells per axis: neighbouring cells would repeat; compare all pairs.
        for (size_t a = 0; a < points.size(); ++a)
            for (size_t b = a + 1; b < points.size(); ++b) consider(a, int(b));
        return edges;
    }
    for (size_t a = 0; a < points.size(); ++a) {
        const Vec3d& p = points[a];
        const int ci = grid.coord(p[0]), cj = grid.coord(p[1]), ck = grid.coord(p[2]);
        for (int i = ci - 1; i <= ci + 1; ++i)
            for (int j = cj - 1; j <= cj + 1; ++j)
                for (int k = ck - 1; k <= ck + 1; ++k)
                    for (int b : grid.at(i, j, k)) {
                        if (b > int(a)) consider(a, b);
                    }
    }
    return edges;
}

} // namespace rockvdb
