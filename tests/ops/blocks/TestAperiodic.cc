// Aperiodic block tiles (implicit-blocks §6.4; corner cubes): regions are functions of their
// colours, blocks never meet across regions, tile faces are not fractures, the tiling fills
// its volume, and it does not repeat with the tile period.
#include <rockvdb/blocks/Aperiodic.h>
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/VdbIO.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace rockvdb;
using namespace rockvdb::blocks;

namespace {

BlockTileParams quick(BlockType type = BlockType::Polyhedral, uint64_t seed = 3)
{
    BlockTileParams p;
    p.type = type;
    p.tileSize = 10.0;
    p.pointRadius = 0.5;
    p.seed = seed;
    return p;
}

} // namespace

TEST(Aperiodic, Explore)
{
    initialize();
    auto tiles = std::make_shared<AperiodicTiles>(quick());
    Task task;
    const auto t0 = std::chrono::steady_clock::now();
    auto f = aperiodicField(tiles, {0, 0, 0}, {2, 2, 2}, task);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const auto made = tiles->regionsMade();
    std::printf("regions %zu %zu %zu %zu in %.2f s\n", made[0], made[1], made[2], made[3], secs);
    for (int M : {0, 1, 6, 7}) {
        const auto& r = tiles->region(M, 0, task);
        std::printf("mask %d: %zu blocks, %zu points, %zu dropped\n", M, r.blocks.size(), r.points, r.dropped);
    }
    const double s = 10;
    int inside = 0, n = 4000, onFace = 0, nf = 4000;
    for (int k = 0; k < n; ++k) {
        const Vec3d q(random::uniform(38, 1, k, 5, 25), random::uniform(38, 2, k, 5, 25),
                      random::uniform(38, 3, k, 5, 25));
        inside += f->eval(q) < 0;
    }
    for (int k = 0; k < nf; ++k) {
        const Vec3d q(s * 1.0, random::uniform(39, 2, k, 5, 25), random::uniform(39, 3, k, 5, 25));
        onFace += f->eval(q) < 0;
    }
    std::printf("fill %.3f, on the face x = s %.3f\n", double(inside) / n, double(onFace) / nf);
}

TEST(Aperiodic, ExploreHoles)
{
    initialize();
    for (double r : {0.5, 0.34}) {
        BlockTileParams p = quick();
        p.pointRadius = r;
        auto tiles = std::make_shared<AperiodicTiles>(p);
        Task task;
        auto f = aperiodicField(tiles, {0, 0, 0}, {2, 2, 2}, task);
        auto tile = std::make_shared<BlockTile>(generateTile(p));
        TileFieldOptions o;
        o.periodic = true;
        auto g = tileField(tile, o);
        int n = 4000, in = 0, inP = 0;
        int holes[4] = {0, 0, 0, 0}, tot[4] = {0, 0, 0, 0}, hist[4] = {0, 0, 0, 0};
        for (int k = 0; k < n; ++k) {
            const Vec3d q(random::uniform(38, 1, k, 5, 25), random::uniform(38, 2, k, 5, 25),
                          random::uniform(38, 3, k, 5, 25));
            const bool rock = f->eval(q) < 0;
            in += rock;
            inP += g->eval(q) < 0;
            double d[3];
            for (int a = 0; a < 3; ++a) d[a] = std::abs(q[a] / 10 - std::floor(q[a] / 10 + 0.5));
            int kind = 3;
            if (d[0] <= 0.25 && d[1] <= 0.25 && d[2] <= 0.25) kind = 0;
            else if ((d[0] <= 0.12) + (d[1] <= 0.12) + (d[2] <= 0.12) >= 2) kind = 1;
            else if (d[0] <= 0.03 || d[1] <= 0.03 || d[2] <= 0.03) kind = 2;
            ++tot[kind];
            holes[kind] += !rock;
            if (!rock) { const double v = f->eval(q); hist[v < 0.05 ? 0 : v < 0.15 ? 1 : v < 0.3 ? 2 : 3]++; }
        }
        std::printf("r %.2f: aperiodic fill %.3f, periodic %.3f; empty by core: v %d/%d e %d/%d f %d/%d c %d/%d\n",
                    r, double(in) / n, double(inP) / n, holes[0], tot[0], holes[1], tot[1], holes[2], tot[2],
                    holes[3], tot[3]);
        std::printf("  empty at distance <5cm %d, <15cm %d, <30cm %d, more %d\n", hist[0], hist[1], hist[2], hist[3]);
    }
}

TEST(Aperiodic, ExploreSlice)
{
    initialize();
    BlockTileParams p = quick();
    p.pointRadius = 0.34;
    auto tiles = std::make_shared<AperiodicTiles>(p);
    Task task;
    auto f = aperiodicField(tiles, {-1, -1, 0}, {3, 3, 2}, task);
    const int N = 600;
    const char* zs = std::getenv("SLICE_Z");
    const double z = zs ? std::atof(zs) : 15.0;
    FILE* out = std::fopen("/tmp/slice.ppm", "wb");
    std::fprintf(out, "P6 %d %d 255\n", N, N);
    for (int j = N - 1; j >= 0; --j)
        for (int i = 0; i < N; ++i) {
            const Vec3d q(i * 30.0 / N, j * 30.0 / N, z);
            float v, id;
            Batch b;
            BatchBuffer bb;
            bb.n = 1; bb.x[0] = float(q[0]); bb.y[0] = float(q[1]); bb.z[0] = float(q[2]);
            f->evalIdBatch(bb.view(), &v, &id);
            unsigned char c[3] = {0, 0, 0};
            {
                double d[3];
                for (int a = 0; a < 3; ++a) d[a] = std::abs(q[a] / 10 - std::floor(q[a] / 10 + 0.5));
                if (d[0] <= 0.25 && d[1] <= 0.25 && d[2] <= 0.25) c[2] = 120;
                else if ((d[0] <= 0.12) + (d[1] <= 0.12) + (d[2] <= 0.12) >= 2) c[1] = 120;
                else if (d[0] <= 0.03 || d[1] <= 0.03 || d[2] <= 0.03) { c[0] = 120; c[1] = 120; }
            }
            if (v < 0) {
                const uint64_t h = random::hash(1, 2, uint64_t(id * 7 + 3));
                c[0] = 80 + (h & 127); c[1] = 80 + ((h >> 8) & 127); c[2] = 80 + ((h >> 16) & 127);
            }
            const double dx = std::abs(q[0] / 10 - std::round(q[0] / 10)), dy = std::abs(q[1] / 10 - std::round(q[1] / 10));
            if (dx < 0.003 || dy < 0.003) { c[0] = 255; c[1] = 0; c[2] = 0; }
            std::fwrite(c, 1, 3, out);
        }
    std::fclose(out);
}

TEST(Aperiodic, ExploreCube)
{
    initialize();
    BlockTileParams p = quick();
    p.pointRadius = 0.34;
    auto tiles = std::make_shared<AperiodicTiles>(p);
    Task task;
    const auto& cube = tiles->region(7, 0, task);
    auto inside = [](const Block& b, const Vec3d& q) {
        double d = -1e300;
        for (const auto& pl : b.planes) d = std::max(d, pl[0] * q[0] + pl[1] * q[1] + pl[2] * q[2] - double(pl[3]));
        return d < 0;
    };
    // the sub-features' blocks
    std::vector<Block> obst;
    for (int m = 0; m < 7; ++m)
        for (int o = 0; o < 8; ++o) {
            if ((o & m) != 0) continue;
            const auto& r = tiles->region(m, 0, task);
            for (Block b : r.blocks) {
                const Vec3d t(10.0 * (o & 1), 10.0 * ((o >> 1) & 1), 10.0 * ((o >> 2) & 1));
                for (auto& pl : b.planes) pl[3] += float(pl[0] * t[0] + pl[1] * t[1] + pl[2] * t[2]);
                obst.push_back(b);
            }
        }
    int n = 3000, own = 0, ob = 0, none = 0, pts = 0;
    for (int k = 0; k < n; ++k) {
        const Vec3d q(random::uniform(38, 1, k, 3, 7), random::uniform(38, 2, k, 3, 7), random::uniform(38, 3, k, 3, 7));
        bool a = false, b = false;
        for (const auto& bl : cube.blocks) a = a || inside(bl, q);
        for (const auto& bl : obst) b = b || inside(bl, q);
        own += a; ob += b; none += !a && !b;
    }
    for (const auto& bl : cube.blocks) pts += bl.points;
    std::printf("cube core centre [3,7]^3: own %d obst %d none %d of %d; %zu blocks, %d points (%zu sampled), dropped %zu\n",
                own, ob, none, n, cube.blocks.size(), pts, cube.points, cube.dropped);
}

#include <rockvdb/blocks/TileBuild.h>
#include <rockvdb/core/Sampling.h>
TEST(Aperiodic, ExploreBuild)
{
    initialize();
    BlockTileParams p = quick();
    p.pointRadius = 0.34;
    p.resolveDefaults();
    p.axis = p.axis.unit();
    Task task;
    const double s = 10;
    auto pts = poissonPeriodic(s, p.pointRadius, p.seed, tilegen::kPoints);
    auto discs = tilegen::makeDiscs(p);
    auto inside = [](const Block& b, const Vec3d& q) {
        double d = -1e300;
        for (const auto& pl : b.planes) d = std::max(d, pl[0] * q[0] + pl[1] * q[1] + pl[2] * q[2] - double(pl[3]));
        return d < 0;
    };
    auto fill = [&](const BlockTile& t, Vec3d off) {
        int n = 2000, in = 0;
        for (int k = 0; k < n; ++k) {
            const Vec3d q = off + Vec3d(random::uniform(38, 1, k, 3, 7), random::uniform(38, 2, k, 3, 7), random::uniform(38, 3, k, 3, 7));
            bool a = false;
            for (const auto& bl : t.blocks) a = a || inside(bl, q);
            in += a;
        }
        return double(in) / n;
    };
    const BlockTile a = tilegen::buildTile(p, pts, discs, task);
    std::printf("periodic as made: %zu blocks, fill %.3f\n", a.blocks.size(), fill(a, Vec3d(0)));
    for (double L : {12.0, 15.0, 20.0}) {
        BlockTileParams q = p;
        q.tileSize = L;
        const BlockTile b = tilegen::buildTile(q, pts, discs, task);
        std::printf("same points in a %.0f m torus: %zu blocks, fill %.3f\n", L, b.blocks.size(), fill(b, Vec3d(0)));
    }
    {
        const double side = 9.4, nr = p.neighbourRadius;
        auto pp = poissonPeriodic(side, p.pointRadius, 77, tilegen::kPoints);
        const Vec3d off(2 * nr - 0.3);
        for (auto& x : pp) x += Vec3d(0.3) + off;
        auto dd = discs;
        for (auto& d : dd) d.center += off;
        BlockTileParams q = p;
        q.tileSize = side + 4 * nr;
        const BlockTile b = tilegen::buildTile(q, pp, dd, task);
        std::printf("9.4 m of points in a %.1f m torus: %zu blocks, fill %.3f\n", q.tileSize, b.blocks.size(), fill(b, off));
        pp = poissonPeriodic(side, p.pointRadius, 77, tilegen::kPoints);
        for (auto& x : pp) x += Vec3d(0.3) + off;
        q.tileSize = 20;
        const BlockTile c = tilegen::buildTile(q, pp, dd, task);
        std::printf("9.4 m of points in a %.1f m torus: %zu blocks, fill %.3f\n", q.tileSize, c.blocks.size(), fill(c, off));
    }
}
