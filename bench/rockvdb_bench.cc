// rockvdb_bench — each issue's numbers beside a reference run in the same process.
// usage: rockvdb_bench [--quick]      (groups: foundation; later stages add theirs)
#include <core/Bake.h>
#include <core/Primitives.h>
#include <core/VdbIO.h>

#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>

using namespace rockvdb;

namespace {

double bestOf(int reps, const std::function<void()>& fn)
{
    double best = 1e30;
    for (int i = 0; i < reps; ++i) {
        const auto t0 = std::chrono::steady_clock::now();
        fn();
        best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return best;
}

void foundation(bool quick)
{
    std::printf("## foundation: sparse baker vs tools::createLevelSetSphere (same run)\n\n");
    std::printf("| sphere | threads | active voxels | rockvdb bake | createLevelSetSphere | ratio | voxels/s (rockvdb) |\n");
    std::printf("|---|---|---|---|---|---|---|\n");
    const double dx = 0.01;
    for (int radiusVoxels : {100, 200}) {
        const double R = radiusVoxels * dx;
        auto field = sphere(Vec3d(0), R);
        BakeSettings s;
        s.voxelSize = dx;
        for (int threads : {1, 2}) {
            tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
            size_t active = 0;
            const int reps = quick ? 2 : 5;
            const double ours = bestOf(reps, [&] { active = bake(*field, s).surface->activeVoxelCount(); });
            const double ref = bestOf(reps, [&] {
                openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(float(R), Vec3f(0), float(dx), 3.0f);
            });
            std::printf("| R=%d voxels | %d | %zu | %.1f ms | %.1f ms | %.1fx | %.3g |\n", radiusVoxels,
                        threads, active, ours * 1e3, ref * 1e3, ref / ours, double(active) / ours);
            std::printf("ratio sphere R=%d threads=%d vs createLevelSetSphere: %.1fx\n", radiusVoxels,
                        threads, ref / ours);
        }
    }
    std::printf("\n## foundation: sparse baker vs the mesh route (volumeToMesh + meshToLevelSet)\n\n");
    std::printf("| sphere | threads | rockvdb bake | mesh route | ratio |\n|---|---|---|---|---|\n");
    for (int radiusVoxels : {100, 200}) {
        const double R = radiusVoxels * dx;
        auto field = sphere(Vec3d(0), R);
        BakeSettings s;
        s.voxelSize = dx;
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        openvdb::FloatGrid::Ptr grid;
        const double ours = bestOf(3, [&] { grid = bake(*field, s).surface; });
        const double mesh = bestOf(1, [&] {
            std::vector<openvdb::Vec3s> pts;
            std::vector<openvdb::Vec3I> tris;
            std::vector<openvdb::Vec4I> quads;
            openvdb::tools::volumeToMesh(*grid, pts, tris, quads, 0.0, 0.0);
            openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(grid->transform(), pts, tris, quads, 3.0f);
        });
        std::printf("| R=%d voxels | 2 | %.1f ms | %.1f ms | %.1fx |\n", radiusVoxels, ours * 1e3,
                    mesh * 1e3, mesh / ours);
        std::printf("ratio sphere R=%d threads=2 vs mesh route: %.1fx\n", radiusVoxels, mesh / ours);
    }
}

} // namespace

int main(int argc, char** argv)
{
    initialize();
    const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
    std::printf("allocator: %s (both sides of every ratio run in this process with it)\n\n",
                ROCKVDB_ALLOCATOR);
    foundation(quick);
    return 0;
}
