// SPDX-License-Identifier: Apache-2.0
// Heightfields: exact distance to tilted planes (also at 60°), image round trips, errors.
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/VdbIO.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <vector>

using namespace rockvdb;

namespace {

std::shared_ptr<Heightfield> plane(double slopeDeg, double azimuthDeg, int n, double cell)
{
    auto hf = std::make_shared<Heightfield>();
    hf->nx = hf->ny = n;
    hf->cellSize = cell;
    const double t = std::tan(slopeDeg * M_PI / 180);
    const double gx = t * std::cos(azimuthDeg * M_PI / 180), gy = t * std::sin(azimuthDeg * M_PI / 180);
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) hf->z.push_back(float(1.0 + gx * i * cell + gy * j * cell));
    return hf;
}

void checkPlane(double slopeDeg, double azimuthDeg)
{
    initialize();
    const double cell = 0.25, dx = 0.05;
    auto hf = plane(slopeDeg, azimuthDeg, 33, cell);
    HeightfieldSettings hs;
    hs.baseDepth = 2.0;
    hs.exactDistance = 0.5;
    BakeSettings s;
    s.voxelSize = dx;
    auto g = bake(*heightfieldField(hf, hs), s).surface;
    const double t = std::tan(slopeDeg * M_PI / 180);
    const Vec3d grad(t * std::cos(azimuthDeg * M_PI / 180), t * std::sin(azimuthDeg * M_PI / 180), 0);
    const double norm = std::sqrt(1 + grad.lengthSqr());
    size_t checked = 0;
    double maxErr = 0;
    const double w = hf->width();
    for (auto it = g->cbeginValueOn(); it; ++it) {
        const Vec3d p = g->transform().indexToWorld(it.getCoord());
        // Away from the walls and the floor (they intersect the surface there).
        if (p[0] < 0.5 || p[1] < 0.5 || p[0] > w - 0.5 || p[1] > w - 0.5) continue;
        const double h = 1.0 + grad[0] * p[0] + grad[1] * p[1];
        if (p[2] < h - 1.0) continue;
        const double expected = (p[2] - h) / norm;
        maxErr = std::max(maxErr, std::abs(double(*it) - expected));
        ++checked;
    }
    EXPECT_GT(checked, 5000u);
    EXPECT_LT(maxErr, 0.05 * dx) << "slope " << slopeDeg;
}

} // namespace

TEST(Heightfield, TiltedPlaneIsExactDistance) { checkPlane(20, 30); }
TEST(Heightfield, SixtyDegreePlaneIsExactDistance) { checkPlane(60, 0); }
TEST(Heightfield, SixtyDegreeDiagonalPlaneIsExactDistance) { checkPlane(60, 45); }

TEST(Heightfield, FieldIsOneLipschitzAcrossFootprintEdges)
{
    // The field is a distance near the surface and a lower bound beyond the caller's reach;
    // switching between the two, and crossing the footprint's edge, must not make it jump
    // (a jump fakes surface voxels under renormalisation). Pairs 2 cm apart straddling the
    // x = 0 and y = 0 edges, at heights above and below the terrain, several reaches.
    auto hf = plane(35, 20, 33, 0.25);
    HeightfieldSettings hs;
    hs.baseDepth = 1.0;
    hs.exactDistance = 0.3;
    auto f = heightfieldField(hf, hs);
    std::vector<float> xs, ys, zs;
    for (int k = 0; k < 400; ++k) {
        const float t = float(k) / 400.0f;
        const float along = 0.3f + 7.0f * t, z = -1.0f + 6.0f * std::fmod(t * 37.0f, 1.0f);
        // (x, y) pairs: across x = 0, then across y = 0.
        xs.insert(xs.end(), {-0.01f, 0.01f, along, along});
        ys.insert(ys.end(), {along, along, -0.01f, 0.01f});
        zs.insert(zs.end(), {z, z, z, z});
    }
    for (float reach : {0.0f, 0.2f, 0.7f, std::numeric_limits<float>::infinity()}) {
        std::vector<float> out(xs.size());
        for (size_t base = 0; base < xs.size(); base += kMaxBatch) {
            Batch b{xs.data() + base, ys.data() + base, zs.data() + base,
                    int(std::min<size_t>(kMaxBatch, xs.size() - base))};
            b.reach = reach;
            f->evalBatch(b, out.data() + base);
        }
        for (size_t i = 0; i < xs.size(); i += 2) {
            ASSERT_LE(std::abs(out[i] - out[i + 1]), 0.02f * 1.001f + 1e-5f)
                << "reach " << reach << " at (" << xs[i] << ", " << ys[i] << ", " << zs[i]
                << "): " << out[i] << " vs " << out[i + 1];
        }
    }
}

TEST(Heightfield, ImageRoundTripAndConvention)
{
    initialize();
    GrayImage img;
    img.width = 4;
    img.height = 3;
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 4; ++i) img.pixels.push_back(float(i + 10 * j) / 100.0f);
    const std::string exr = ::testing::TempDir() + "/hf_rt.exr";
    const std::string png = ::testing::TempDir() + "/hf_rt.png";
    writeGrayImage(exr, img);
    writeGrayImage(png, img);
    const Heightfield a = loadHeightfield(exr, 2.0, 10.0);
    const Heightfield b = loadHeightfield(png, 2.0, 10.0);
    ASSERT_EQ(a.nx, 4);
    ASSERT_EQ(a.ny, 3);
    // Column i, row j (first stored row = 0) -> value(i, j)·heightScale.
    EXPECT_FLOAT_EQ(a.at(3, 2), 2.3f * 10.0f / 10.0f * 1.0f);
    EXPECT_NEAR(b.at(3, 2), 2.3, 10.0 / 65535.0);
    EXPECT_NEAR(b.at(1, 0), 0.1, 10.0 / 65535.0);
}

TEST(Heightfield, BadImagesGiveClearErrors)
{
    EXPECT_THROW(loadHeightfield("/nonexistent/x.exr", 1, 1), IoError);
    const std::string junk = ::testing::TempDir() + "/junk.png";
    { std::ofstream(junk) << "not an image at all"; }
    EXPECT_THROW(loadHeightfield(junk, 1, 1), IoError);
    EXPECT_THROW(loadHeightfield(junk, -1, 1), ValueError);
    // An 8-bit RGB PNG is refused with what it is.
    std::vector<uint8_t> rgb(4 * 4 * 3, 128);
    const std::string rgbPath = ::testing::TempDir() + "/rgb8.png";
    { std::ofstream f(rgbPath, std::ios::binary); const auto b = encodePngRgb8(4, 4, rgb); f << b; }
    try {
        loadHeightfield(rgbPath, 1, 1);
        FAIL();
    } catch (const ValueError& e) {
        EXPECT_NE(std::string(e.what()).find("8-bit RGB"), std::string::npos) << e.what();
    }
}

TEST(Heightfield, SeaCliffProfile)
{
    // Plateau at small x, floor beyond the coast, the face's steepest slope at its mid-line
    // (1.5·(height − floor)/width for the smoothstep), bays and headlands of about ±waviness.
    SeaCliff c;
    c.nx = 161;
    c.ny = 121;
    c.cellSize = 0.5;
    c.height = 28;
    c.floor = 2;
    c.coast = 40;
    c.width = 10;
    c.waviness = 5;
    c.roughness = 0;
    const Heightfield hf = seaCliffHeightfield(c);
    ASSERT_EQ(hf.nx, 161);
    ASSERT_EQ(hf.ny, 121);
    double lo = 1e9, hi = -1e9, steepest = 0;
    for (int j = 0; j < hf.ny; ++j) {
        EXPECT_FLOAT_EQ(hf.at(0, j), 28.0f);     // plateau (x = 0 is > 12 m from any coast)
        EXPECT_FLOAT_EQ(hf.at(160, j), 2.0f);    // sea floor at x = 80 m
        int cross = -1;
        for (int i = 1; i < hf.nx; ++i) {
            steepest = std::max(steepest, double(hf.at(i - 1, j) - hf.at(i, j)) / c.cellSize);
            if (cross < 0 && hf.at(i, j) < 15.0f) cross = i;
        }
        lo = std::min(lo, cross * c.cellSize);
        hi = std::max(hi, cross * c.cellSize);
    }
    EXPECT_NEAR(steepest, 1.5 * 26 / 10, 0.1);
    // The mid-height line wanders with the coastline: both bays and headlands, within reach.
    EXPECT_GT(hi - lo, 5.0);
    EXPECT_LT(hi - lo, 2 * (1.0 + 0.5) * 5 + 1);
    EXPECT_GT(lo, 40 - 8.5);
    EXPECT_LT(hi, 40 + 8.5);
    // Same parameters, same heights; another seed, another coastline.
    EXPECT_EQ(seaCliffHeightfield(c).z, hf.z);
    SeaCliff d = c;
    d.seed = 2;
    EXPECT_NE(seaCliffHeightfield(d).z, hf.z);
    SeaCliff bad = c;
    bad.height = 1;
    EXPECT_THROW(seaCliffHeightfield(bad), ValueError);
}

namespace {

// Distance from p to triangle abc by brute force: the plane's foot point if it falls inside,
// else the nearest of the three edges (segment distances), in double.
double segmentDistance(const Vec3d& p, const Vec3d& a, const Vec3d& b)
{
    const Vec3d ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / ab.lengthSqr(), 0.0, 1.0);
    return (p - (a + ab * t)).length();
}

double triangleDistance(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c)
{
    Vec3d n = (b - a).cross(c - a);
    n.normalize();
    const double d = (p - a).dot(n);
    const Vec3d q = p - n * d;
    // Barycentric inside test on the plane.
    auto side = [&](const Vec3d& u, const Vec3d& v) { return (v - u).cross(q - u).dot(n); };
    if (side(a, b) >= 0 && side(b, c) >= 0 && side(c, a) >= 0) return std::abs(d);
    return std::min({segmentDistance(p, a, b), segmentDistance(p, b, c), segmentDistance(p, c, a)});
}

} // namespace

TEST(Heightfield, ExactWithinTheReachAndALowerBoundBeyondOnASteepRoughTerrain)
{
    // The search is pruned by a local cone bound and by the reach: neither may lose the
    // nearest triangle. A 16 x 16 m sea cliff (face steeper than 70 degrees, rough), points
    // everywhere within 3 m of it: within the batch's reach the field is the distance to
    // the nearest of all triangles (brute force), beyond it a lower bound of that distance
    // no smaller than the reach.
    SeaCliff c;
    c.nx = c.ny = 33;
    c.cellSize = 0.5;
    c.height = 12;
    c.coast = 8;
    c.width = 2.5;
    c.waviness = 1.5;
    c.roughness = 0.8;
    c.roughnessFrequency = 0.4;
    auto hf = std::make_shared<Heightfield>(seaCliffHeightfield(c));
    HeightfieldSettings hs;
    hs.closed = false;
    hs.exactDistance = 0.4;
    auto f = heightfieldField(hf, hs);
    std::vector<float> xs, ys, zs;
    uint64_t state = 12345;
    auto next = [&] {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return double(state >> 11) / double(1ull << 53);
    };
    for (int k = 0; k < 4000; ++k) {
        const double x = 0.5 + 15 * next(), y = 0.5 + 15 * next();
        int i = std::min(int(x / c.cellSize), c.nx - 2), j = std::min(int(y / c.cellSize), c.ny - 2);
        xs.push_back(float(x));
        ys.push_back(float(y));
        zs.push_back(float(hf->at(i, j) + (next() - 0.5) * 6.0));
    }
    for (float reach : {0.3f, 0.8f, 1.4f}) {
        std::vector<float> out(xs.size());
        for (size_t base = 0; base < xs.size(); base += kMaxBatch) {
            Batch b{xs.data() + base, ys.data() + base, zs.data() + base,
                    int(std::min<size_t>(kMaxBatch, xs.size() - base))};
            b.reach = reach;
            f->evalBatch(b, out.data() + base);
        }
        size_t exact = 0;
        for (size_t k = 0; k < xs.size(); ++k) {
            const Vec3d p(xs[k], ys[k], zs[k]);
            double best = 1e30;
            const double cs = hf->cellSize;
            for (int j = 0; j + 1 < hf->ny; ++j)
                for (int i = 0; i + 1 < hf->nx; ++i) {
                    const Vec3d a(i * cs, j * cs, hf->at(i, j)), b((i + 1) * cs, j * cs, hf->at(i + 1, j)),
                        d((i + 1) * cs, (j + 1) * cs, hf->at(i + 1, j + 1)), e(i * cs, (j + 1) * cs, hf->at(i, j + 1));
                    best = std::min({best, triangleDistance(p, a, b, d), triangleDistance(p, a, d, e)});
                }
            const double got = std::abs(double(out[k]));
            if (best <= reach) {
                ASSERT_NEAR(got, best, 1e-5) << "at " << p << " reach " << reach;
                ++exact;
            } else {
                ASSERT_LE(got, best + 1e-5) << "not a lower bound at " << p;
                ASSERT_GE(got, reach - 1e-5) << "below the reach at " << p;
            }
        }
        EXPECT_GT(exact, 300u) << "reach " << reach;
    }
}
