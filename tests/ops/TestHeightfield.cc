// Heightfields: exact distance to tilted planes (also at 60°), image round trips, errors.
#include <core/Bake.h>
#include <core/Error.h>
#include <core/Heightfield.h>
#include <core/Image.h>
#include <core/VdbIO.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>

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
