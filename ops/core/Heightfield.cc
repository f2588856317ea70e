// SPDX-License-Identifier: Apache-2.0
#include "Heightfield.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/Random.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

namespace rockvdb {

void Heightfield::validate(const char* op) const
{
    require(nx >= 2 && ny >= 2, op, "heightfield size", "at least 2x2 samples",
            std::to_string(nx) + "x" + std::to_string(ny));
    require(std::isfinite(cellSize) && cellSize > 0, op, "cell size", "> 0", cellSize);
    require(z.size() == size_t(nx) * size_t(ny), op, "heightfield sample count", "nx·ny",
            z.size());
    for (float v : z) {
        if (!std::isfinite(v)) fail<ValueError>(op, ": heightfield holds NaN or infinite values");
    }
}

Heightfield loadHeightfield(const std::string& path, double cellSize, double heightScale,
                            double maxMemoryBytes)
{
    require(std::isfinite(cellSize) && cellSize > 0, "heightfield", "cell size", "> 0", cellSize);
    require(std::isfinite(heightScale), "heightfield", "height scale", "finite", heightScale);
    const GrayImage img = readGrayImage(path, "heightfield", maxMemoryBytes);
    Heightfield hf;
    hf.nx = img.width;
    hf.ny = img.height;
    hf.cellSize = cellSize;
    hf.z.resize(img.pixels.size());
    for (size_t k = 0; k < hf.z.size(); ++k) hf.z[k] = float(double(img.pixels[k]) * heightScale);
    return hf;
}

Heightfield noiseHeightfield(int nx, int ny, double cellSize, double amplitude,
                             const noise::Fbm& fbm, uint64_t seed)
{
    fbm.validate("heightfield");
    require(nx >= 2 && ny >= 2 && double(nx) * ny <= 1e9, "heightfield", "size",
            "between 2x2 and 1e9 samples", std::to_string(nx) + "x" + std::to_string(ny));
    require(std::isfinite(cellSize) && cellSize > 0, "heightfield", "cell size", "> 0", cellSize);
    require(std::isfinite(amplitude), "heightfield", "amplitude", "finite", amplitude);
    // Samples sit at float positions: past 1e9 m they are no longer distinct (nor finite).
    const double extent = double(std::max(nx, ny) - 1) * cellSize;
    require(extent <= 1e9, "heightfield", "extent (samples x cell size)", "<= 1e9 m", extent);
    Heightfield hf;
    hf.nx = nx;
    hf.ny = ny;
    hf.cellSize = cellSize;
    hf.z.resize(size_t(nx) * size_t(ny));
    const float scale = float(amplitude / fbm.amplitudeSum());
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
            hf.z[size_t(j) * size_t(nx) + size_t(i)] =
                scale * noise::fbm2(seed, fbm, float(i * cellSize), float(j * cellSize));
    return hf;
}

void SeaCliff::validate() const
{
    const char* op = "sea_cliff";
    require(nx >= 2 && ny >= 2 && double(nx) * ny <= 1e9, op, "samples",
            "between 2x2 and 1e9 samples", std::to_string(nx) + "x" + std::to_string(ny));
    require(std::isfinite(cellSize) && cellSize > 0, op, "cell size", "> 0 m", cellSize);
    require(std::isfinite(height) && std::isfinite(floor) && height > floor, op, "height",
            "> floor (m)", height);
    require(std::isfinite(coast), op, "coast", "finite (m)", coast);
    require(std::isfinite(width) && width > 0, op, "width", "> 0 m", width);
    require(std::isfinite(waviness) && waviness >= 0, op, "waviness", ">= 0 m", waviness);
    require(std::isfinite(coastFrequency) && coastFrequency > 0, op, "coast frequency",
            "> 0 per m", coastFrequency);
    require(std::isfinite(roughness) && roughness >= 0, op, "roughness", ">= 0 m", roughness);
    require(std::isfinite(roughnessFrequency) && roughnessFrequency > 0, op,
            "roughness frequency", "> 0 per m", roughnessFrequency);
}

Heightfield seaCliffHeightfield(const SeaCliff& c)
{
    c.validate();
    Heightfield hf;
    hf.nx = c.nx;
    hf.ny = c.ny;
    hf.cellSize = c.cellSize;
    hf.z.resize(size_t(c.nx) * size_t(c.ny));
    noise::Fbm shore;
    shore.frequency = c.coastFrequency;
    shore.octaves = 3;
    noise::Fbm rough;
    rough.frequency = c.roughnessFrequency;
    rough.octaves = 5;
    const double shoreScale = 0.5 * c.waviness / shore.amplitudeSum();
    const double phase[2] = {2.0 * M_PI * random::uniform(c.seed, 91, 0),
                             2.0 * M_PI * random::uniform(c.seed, 91, 1)};
    const double roughScale = c.roughness / rough.amplitudeSum();
    for (int j = 0; j < c.ny; ++j) {
        const double y = j * c.cellSize;
        // The coastline: two sines of seeded phase (bays and headlands of about waviness
        // metres) plus 1D noise along y (a row of the 2D noise far from the surface's).
        const double w = 2.0 * M_PI * c.coastFrequency * y;
        const double coast = c.coast +
            c.waviness * (0.7 * std::sin(w + phase[0]) + 0.3 * std::sin(2.3 * w + phase[1])) +
            shoreScale * noise::fbm2(c.seed, shore, float(y), 517.0f);
        for (int i = 0; i < c.nx; ++i) {
            const double x = i * c.cellSize;
            const double t = std::clamp((coast - x) / c.width + 0.5, 0.0, 1.0);
            const double s = t * t * (3.0 - 2.0 * t);
            const double z = c.floor + (c.height - c.floor) * s +
                             roughScale * noise::fbm2(c.seed + 1, rough, float(x), float(y));
            hf.z[size_t(j) * size_t(c.nx) + size_t(i)] = float(z);
        }
    }
    return hf;
}

namespace {

// Closest distance² from p to triangle abc (Ericson, Real-Time Collision Detection §5.1.5).
inline double pointTriangleDist2(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c)
{
    const Vec3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) return ap.lengthSqr();
    const Vec3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) return bp.lengthSqr();
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return (ap - ab * (d1 / (d1 - d3))).lengthSqr();
    const Vec3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) return cp.lengthSqr();
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return (ap - ac * (d2 / (d2 - d6))).lengthSqr();
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (bp - (c - b) * w).lengthSqr();
    }
    const double denom = 1.0 / (va + vb + vc);
    const double v = vb * denom, w = vc * denom;
    return (ap - ab * v - ac * w).lengthSqr();
}

class HeightfieldField final : public Field
{
public:
    HeightfieldField(std::shared_ptr<const Heightfield> hf, const HeightfieldSettings& s)
        : mHf(std::move(hf)), mS(s)
    {
        const Heightfield& h = *mHf;
        mZMin = *std::min_element(h.z.begin(), h.z.end());
        mZMax = *std::max_element(h.z.begin(), h.z.end());
        mBase = mZMin - s.baseDepth;
        const int cx = h.nx - 1, cy = h.ny - 1;
        mCellMin.resize(size_t(cx) * size_t(cy));
        mCellMax.resize(mCellMin.size());
        mCellSlope.resize(mCellMin.size());
        double slope = 0;
        const double c = h.cellSize;
        for (int j = 0; j < cy; ++j)
            for (int i = 0; i < cx; ++i) {
                const double z00 = h.at(i, j), z10 = h.at(i + 1, j), z01 = h.at(i, j + 1),
                             z11 = h.at(i + 1, j + 1);
                const size_t k = size_t(j) * size_t(cx) + size_t(i);
                mCellMin[k] = float(std::min({z00, z10, z01, z11}));
                mCellMax[k] = float(std::max({z00, z10, z01, z11}));
                // Gradients of the two triangles of the cell.
                const double g1 = std::hypot(z10 - z00, z11 - z10) / c;
                const double g2 = std::hypot(z11 - z01, z01 - z00) / c;
                mCellSlope[k] = float(std::max(g1, g2));
                slope = std::max({slope, g1, g2});
            }
        mConeFactor = 1.0 / std::sqrt(1.0 + slope * slope);
    }

    void evalBatch(const Batch& b, float* out) const override
    {
        // Exact within the caller's reach (a bake's band needs no more); without one, within
        // exactDistance. A lower bound beyond.
        const double rho = std::isfinite(b.reach) ? double(b.reach) : mS.exactDistance;
        const Window& w = window(rho);
        for (int i = 0; i < b.n; ++i) {
            out[i] = float(eval1(Vec3d(b.x[i], b.y[i], b.z[i]), rho, w));
        }
    }

    BBoxd bounds() const override
    {
        return BBoxd(Vec3d(0, 0, mBase), Vec3d(mHf->width(), mHf->depth(), mZMax));
    }

    bool exact() const override { return true; }

private:
    // The local cone bound: cone[k] = 1/sqrt(1 + S²), S the steepest triangle within
    // `radius` cells of cell k (a square window, clipped to the grid). Surface points outside
    // the window lie at least radius·cellSize away horizontally; inside it the height is
    // S-Lipschitz along any segment (the window is convex), so they are at least
    // |v|/sqrt(1 + S²) away. Built once per radius (a bake asks for one or two).
    struct Window
    {
        int radius = 0;
        double reach = 0; ///< radius·cellSize: the bound's cap
        std::vector<float> cone;
    };

    const Window& window(double rho) const
    {
        const Heightfield& h = *mHf;
        const int cx = h.nx - 1, cy = h.ny - 1;
        // The smallest radius whose cap radius·cellSize exceeds rho: a cap equal to rho (rho a
        // multiple of the cell size, e.g. the demo's 0.25 m voxels on 0.5 m cells) could never
        // prove a point beyond rho, and every point within the cone's reach was searched ring by
        // ring (the bake of that terrain 3x slower; values the same).
        const int radius = int(std::min(std::floor(rho / h.cellSize) + 1.0, double(std::max(cx, cy))));
        std::lock_guard<std::mutex> lock(mWindowMutex);
        for (const auto& w : mWindows) if (w->radius == radius) return *w;
        auto w = std::make_unique<Window>();
        w->radius = radius;
        w->reach = radius * h.cellSize;
        // Separable running maximum, rows then columns, each in O(n) whatever the radius.
        std::vector<float> rows(mCellSlope.size());
        std::vector<float> line, out;
        for (int j = 0; j < cy; ++j) {
            line.assign(mCellSlope.begin() + ptrdiff_t(size_t(j) * size_t(cx)),
                        mCellSlope.begin() + ptrdiff_t(size_t(j + 1) * size_t(cx)));
            runningMax(line, radius, out);
            std::copy(out.begin(), out.end(), rows.begin() + ptrdiff_t(size_t(j) * size_t(cx)));
        }
        w->cone.resize(mCellSlope.size());
        for (int i = 0; i < cx; ++i) {
            line.resize(size_t(cy));
            for (int j = 0; j < cy; ++j) line[size_t(j)] = rows[size_t(j) * size_t(cx) + size_t(i)];
            runningMax(line, radius, out);
            for (int j = 0; j < cy; ++j) {
                const double m = out[size_t(j)];
                w->cone[size_t(j) * size_t(cx) + size_t(i)] = float(1.0 / std::sqrt(1.0 + m * m));
            }
        }
        mWindows.push_back(std::move(w));
        return *mWindows.back();
    }

    // out[i] = max of in[i - r .. i + r] (clipped), for values >= 0: van Herk / Gil-Werman,
    // prefix and suffix maxima over blocks of 2r + 1.
    static void runningMax(const std::vector<float>& in, int r, std::vector<float>& out)
    {
        const size_t n = in.size(), w = size_t(2 * r + 1);
        std::vector<float> g(n), h(n);
        for (size_t i = 0; i < n; ++i) g[i] = i % w == 0 ? in[i] : std::max(g[i - 1], in[i]);
        for (size_t i = n; i-- > 0;) {
            h[i] = (i + 1) % w == 0 || i + 1 == n ? in[i] : std::max(h[i + 1], in[i]);
        }
        out.resize(n);
        for (size_t i = 0; i < n; ++i) {
            const size_t lo = i >= size_t(r) ? i - size_t(r) : 0;
            const size_t hi = std::min(n - 1, i + size_t(r));
            // [lo, hi] spans at most two blocks: the suffix of lo's and the prefix of hi's.
            // Within one block it starts the block (else it would be w long and span two)
            // or ends the line.
            out[i] = lo / w != hi / w ? std::max(h[lo], g[hi]) : lo % w == 0 ? g[hi] : h[lo];
        }
    }

    // Height of the triangulated surface at (x, y), clamped to the footprint.
    double heightAt(double x, double y, int& ci, int& cj) const
    {
        const Heightfield& h = *mHf;
        const double u = std::clamp(x / h.cellSize, 0.0, double(h.nx - 1));
        const double v = std::clamp(y / h.cellSize, 0.0, double(h.ny - 1));
        ci = std::min(int(u), h.nx - 2);
        cj = std::min(int(v), h.ny - 2);
        const double fu = u - ci, fv = v - cj;
        const double z00 = h.at(ci, cj), z10 = h.at(ci + 1, cj), z01 = h.at(ci, cj + 1),
                     z11 = h.at(ci + 1, cj + 1);
        return fu >= fv ? z00 + fu * (z10 - z00) + fv * (z11 - z10)
                        : z00 + fv * (z01 - z00) + fu * (z11 - z01);
    }

    // Unsigned distance to the two triangles of cell (i, j), squared.
    double cellDist2(const Vec3d& p, int i, int j) const
    {
        const Heightfield& h = *mHf;
        const double c = h.cellSize;
        const Vec3d a(i * c, j * c, h.at(i, j)), b((i + 1) * c, j * c, h.at(i + 1, j)),
            d((i + 1) * c, (j + 1) * c, h.at(i + 1, j + 1)), e(i * c, (j + 1) * c, h.at(i, j + 1));
        return std::min(pointTriangleDist2(p, a, b, d), pointTriangleDist2(p, a, d, e));
    }

    double surfaceDistance(const Vec3d& p, double rho, const Window& win) const
    {
        const Heightfield& h = *mHf;
        const double c = h.cellSize;
        int ci, cj;
        const double v = p[2] - heightAt(p[0], p[1], ci, cj);
        const double sign = v > 0 ? 1.0 : -1.0;
        // Horizontal distance outside the footprint.
        const double ox = std::max({0.0, -p[0], p[0] - h.width()});
        const double oy = std::max({0.0, -p[1], p[1] - h.depth()});
        const double dh = std::hypot(ox, oy);
        // Lower bound of the distance: the cone bound |v|/sqrt(1 + S²) at p' = p clamped to
        // the footprint (S = steepest triangle slope), combined with the horizontal gap dh =
        // |p - p'|: projecting onto the convex footprint column is non-expansive, so
        // |p - q|² >= dh² + |p' - q|² for every q of the terrain. Continuous across the
        // footprint's edge and 1-Lipschitz (the two terms vary along orthogonal directions).
        // The window's local cone is tighter wherever the steepest slope is elsewhere, but
        // steps from cell to cell: beyond rho the values are bounds only, which bakes never
        // read as distances (their reach and clamp band).
        const int cx = h.nx - 1, cy = h.ny - 1;
        const double local = std::min(
            win.reach, std::abs(v) * double(win.cone[size_t(cj) * size_t(cx) + size_t(ci)]));
        const double vert = std::max(std::abs(v) * mConeFactor, local);
        const double lb = std::sqrt(dh * dh + vert * vert);
        if (lb > rho) return sign * lb;
        // Exact: search cells ring by ring around (ci, cj) while a ring can still be closer
        // than the best so far and than rho (beyond rho the lower bound is the answer).
        // Rings beyond the grid hold no cells: the search ends there however small the
        // cells are against rho (a 1e-9 m cell size would otherwise ask for 1e8 rings).
        const int gridRing = std::max({ci, cx - 1 - ci, cj, cy - 1 - cj});
        const int maxRing = int(std::min(std::ceil(rho / c) + 1.0, double(gridRing)));
        const double rho2 = std::nextafter(rho * rho, std::numeric_limits<double>::infinity());
        double best2 = rho2;
        for (int r = 0; r <= maxRing; ++r) {
            const double ringGap = std::max(0.0, (r - 1) * c);
            if (ringGap * ringGap >= best2) break;
            for (int j = std::max(cj - r, 0); j <= std::min(cj + r, cy - 1); ++j) {
                const bool edgeRow = (j == cj - r || j == cj + r);
                for (int i = ci - r; i <= ci + r; i += (edgeRow ? 1 : 2 * r)) {
                    if (i >= 0 && i < cx) {
                        const size_t k = size_t(j) * size_t(cx) + size_t(i);
                        const double gx = std::max({0.0, i * c - p[0], p[0] - (i + 1) * c});
                        const double gy = std::max({0.0, j * c - p[1], p[1] - (j + 1) * c});
                        const double gz = std::max({0.0, double(mCellMin[k]) - p[2],
                                                    p[2] - double(mCellMax[k])});
                        const double lb2 = gx * gx + gy * gy + gz * gz;
                        if (lb2 < best2) best2 = std::min(best2, cellDist2(p, i, j));
                    }
                    if (r == 0) break;
                }
            }
        }
        const double best = std::sqrt(best2);
        return sign * (best2 < rho2 && best <= rho ? best : std::max(rho, lb));
    }

    double eval1(const Vec3d& p, double rho, const Window& win) const
    {
        const double s = surfaceDistance(p, rho, win);
        if (!mS.closed) return s;
        // Footprint walls and floor: box [0, W] x [0, D] x [base, zmax + 1].
        const Heightfield& h = *mHf;
        const double qx = std::max(-p[0], p[0] - h.width());
        const double qy = std::max(-p[1], p[1] - h.depth());
        const double qz = std::max(mBase - p[2], p[2] - (mZMax + 1.0));
        const double ox = std::max(qx, 0.0), oy = std::max(qy, 0.0), oz = std::max(qz, 0.0);
        const double walls = std::sqrt(ox * ox + oy * oy + oz * oz) +
                             std::min(std::max({qx, qy, qz}), 0.0);
        return std::max(s, walls);
    }

    std::shared_ptr<const Heightfield> mHf;
    HeightfieldSettings mS;
    float mZMin = 0, mZMax = 0;
    double mBase = 0, mConeFactor = 1;
    std::vector<float> mCellMin, mCellMax, mCellSlope;
    mutable std::mutex mWindowMutex;
    mutable std::vector<std::unique_ptr<Window>> mWindows;
};

} // namespace

FieldPtr heightfieldField(std::shared_ptr<const Heightfield> hf, const HeightfieldSettings& s)
{
    if (!hf) fail<ValueError>("heightfield: heightfield is null");
    hf->validate("heightfield");
    require(std::isfinite(s.baseDepth) && s.baseDepth > 0, "heightfield", "base depth", "> 0",
            s.baseDepth);
    require(std::isfinite(s.exactDistance) && s.exactDistance > 0, "heightfield",
            "exact distance", "> 0", s.exactDistance);
    return std::make_shared<HeightfieldField>(std::move(hf), s);
}

} // namespace rockvdb
