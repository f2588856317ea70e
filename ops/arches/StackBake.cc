// SPDX-License-Identifier: Apache-2.0
// Level sets of material stacks (see StackBake.h).
#include "StackBake.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridUtil.h>

#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tools/FastSweeping.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

namespace rockvdb {
namespace arches {

namespace {

// reach = 0: the §3.3 box convolution −σ·f; else Skeleton::interpolated with that reach.
class ConvolutionField : public Field
{
public:
    ConvolutionField(std::shared_ptr<const Skeleton> s, double sigma, double reach)
        : mSkeleton(std::move(s)), mSigma(sigma), mReach(reach)
    {
        const auto& g = mSkeleton->geometry();
        const double top = mSkeleton->top(), z = std::max(sigma, reach);
        mBounds = BBoxd(Vec3d(g.x0 - sigma, g.y0 - sigma, g.z0 - z),
                        Vec3d(g.x0 + g.nx * g.cell + sigma, g.y0 + g.ny * g.cell + sigma, top + z));
    }

    void evalBatch(const Batch& b, float* out) const override
    {
        for (int i = 0; i < b.n; ++i) {
            const Vec3d p(b.x[i], b.y[i], b.z[i]);
            out[i] = float(mReach > 0 ? mSkeleton->interpolated(p, mSigma, mReach) : -mSigma * mSkeleton->field(p, mSigma));
        }
    }
    BBoxd bounds() const override { return mBounds; }
    // Box: |∂f/∂x| <= 1/σ per axis (a slab of the cube enters, one leaves): σ·f is
    // √3-Lipschitz. Interpolate: |∂/∂z| <= 1, and per horizontal axis the weights move area
    // at 2σ per unit between values at most 2R apart, over 4σ²: R/σ.
    double lipschitz() const override
    {
        return mReach > 0 ? std::sqrt(1.0 + 2.0 * (mReach / mSigma) * (mReach / mSigma)) : std::sqrt(3.0);
    }
    bool exact() const override { return false; }

private:
    std::shared_ptr<const Skeleton> mSkeleton;
    double mSigma, mReach;
    BBoxd mBounds;
};

// The leaves that can hold voxels within reach R of the convolution surface. The surface lies
// where the σ-cube holds both skeleton and not (within σ, ∞-norm, of an interval end or of a
// height where neighbouring stacks disagree); so, per column of leaves, over the stacks within
// R of its footprint: every interval end ± R, and every height range where those stacks (and
// the empty outside, when the footprint leaves the grid) do not all agree, ± R.
openvdb::MaskGrid::Ptr candidateLeaves(const Skeleton& sk, double dx, double reach, double maxMemoryBytes, Task& task)
{
    const auto& g = sk.geometry();
    const double xmin = g.x0 - reach, xmax = g.x0 + g.nx * g.cell + reach;
    const double ymin = g.y0 - reach, ymax = g.y0 + g.ny * g.cell + reach;
    // One list per column of leaves (~32 bytes each before any leaf): refuse absurd sizes
    // before allocating (and before index coordinates could overflow).
    const double wide = (xmax - xmin) / dx / 8.0 + 2.0, deep = (ymax - ymin) / dx / 8.0 + 2.0;
    const double estimate = wide * deep * 32.0, limit = memoryLimitBytes(maxMemoryBytes);
    if (!(estimate <= limit)) {
        fail<ValueError>("arches: the level set's ", wide, " x ", deep, " columns of leaves need at least ",
                         formatBytes(estimate), ", over the ", formatBytes(limit),
                         " allowed; use a larger voxel size or raise --max-memory");
    }
    const double top = sk.top();
    const double far = std::max({std::abs(xmin), std::abs(xmax), std::abs(ymin), std::abs(ymax), std::abs(g.z0) + reach,
                                 std::abs(top) + reach}) / dx;
    if (!(far < 1e9)) {
        fail<ValueError>("arches: the terrain reaches ", far, " voxels from the origin, beyond the 1e9 an index holds; use a larger voxel size");
    }
    const int lx0 = floorDiv(int(std::floor(xmin / dx)), 8), lx1 = floorDiv(int(std::ceil(xmax / dx)), 8);
    const int ly0 = floorDiv(int(std::floor(ymin / dx)), 8), ly1 = floorDiv(int(std::ceil(ymax / dx)), 8);
    const size_t ncx = size_t(lx1 - lx0 + 1), ncy = size_t(ly1 - ly0 + 1);
    std::vector<std::vector<int>> columns(ncx * ncy); // leaf z indices per column
    parallelFor(task, ncy, 1, [&](size_t cy) {
        std::vector<std::pair<double, int>> events;
        std::vector<std::pair<double, double>> ranges;
        for (size_t cx = 0; cx < ncx; ++cx) {
            const int lx = lx0 + int(cx), ly = ly0 + int(cy);
            const double fx0 = (8 * lx) * dx - reach, fx1 = (8 * lx + 7) * dx + reach;
            const double fy0 = (8 * ly) * dx - reach, fy1 = (8 * ly + 7) * dx + reach;
            const int i0 = int(std::floor((fx0 - g.x0) / g.cell)), i1 = int(std::floor((fx1 - g.x0) / g.cell));
            const int j0 = int(std::floor((fy0 - g.y0) / g.cell)), j1 = int(std::floor((fy1 - g.y0) / g.cell));
            const int ci0 = std::max(i0, 0), ci1 = std::min(i1, g.nx - 1);
            const int cj0 = std::max(j0, 0), cj1 = std::min(j1, g.ny - 1);
            if (ci0 > ci1 || cj0 > cj1) continue;
            const bool outside = i0 < 0 || j0 < 0 || i1 >= g.nx || j1 >= g.ny; // an empty "stack"
            const int stacks = (ci1 - ci0 + 1) * (cj1 - cj0 + 1) + (outside ? 1 : 0);
            events.clear();
            for (int j = cj0; j <= cj1; ++j)
                for (int i = ci0; i <= ci1; ++i) {
                    const size_t s = g.index(i, j);
                    for (size_t k = 0; k < sk.intervalCount(s); ++k) {
                        events.emplace_back(sk.start(s, k), +1);
                        events.emplace_back(sk.end(s, k), -1);
                    }
                }
            if (events.empty()) continue;
            std::sort(events.begin(), events.end());
            ranges.clear();
            int inside = 0;
            for (size_t e = 0; e < events.size(); ++e) {
                ranges.emplace_back(events[e].first - reach, events[e].first + reach);
                inside += events[e].second;
                // Between this end and the next, do the stacks disagree?
                if (e + 1 < events.size() && inside > 0 && inside < stacks) {
                    ranges.emplace_back(events[e].first - reach, events[e + 1].first + reach);
                }
            }
            std::vector<int>& leaves = columns[cy * ncx + cx];
            for (const auto& [lo, hi] : ranges) {
                const int k0 = floorDiv(int(std::ceil(lo / dx)), 8), k1 = floorDiv(int(std::floor(hi / dx)), 8);
                for (int k = k0; k <= k1; ++k) leaves.push_back(k);
            }
            std::sort(leaves.begin(), leaves.end());
            leaves.erase(std::unique(leaves.begin(), leaves.end()), leaves.end());
        }
    });
    auto mask = openvdb::MaskGrid::create(false);
    auto acc = mask->getAccessor();
    for (size_t c = 0; c < columns.size(); ++c) {
        const int lx = lx0 + int(c % ncx), ly = ly0 + int(c / ncx);
        for (const int k : columns[c]) acc.setValueOn(openvdb::Coord(8 * lx, 8 * ly, 8 * k));
    }
    return mask;
}

// OpenVDB's fast sweeping cannot be interrupted, and on a 1 000 x 750 terrain one sweep runs
// for seconds. So the band is swept in xy tiles of kTile voxels, each with a halo of at least
// w + 2 voxels (whole leaves): every zero crossing within the band of a tile's own voxels is in
// its sweep. Tiles run in parallel with the task checked between them (Ctrl-C waits for one
// tile, ~0.1 s at 1 m on a 1 000 x 750 terrain); they depend only on index coordinates, never
// on thread count, and each tile's own leaves are taken from its sweep alone, so the result
// is deterministic. Halo leaves are swept by up to 4 tiles: ~27% more voxels swept than once
// at w = 3, and the bake took as long as with one sweep (bench `arches`).
openvdb::FloatGrid::Ptr sweepTiled(const openvdb::FloatGrid& in, double w, Task& task)
{
    using Leaf = openvdb::FloatTree::LeafNodeType;
    constexpr int kTile = 128;
    const int halo = 8 * int(std::ceil((std::ceil(w) + 2.0) / 8.0));
    std::vector<const Leaf*> leaves;
    in.tree().getNodes(leaves);
    // Each tile's swept leaves (its own and its halo's), tiles in key order.
    std::map<std::pair<int, int>, std::vector<uint32_t>> tiles;
    for (size_t l = 0; l < leaves.size(); ++l) {
        const openvdb::Coord o = leaves[l]->origin();
        for (int ty = floorDiv(o.y() - halo, kTile); ty <= floorDiv(o.y() + halo, kTile); ++ty)
            for (int tx = floorDiv(o.x() - halo, kTile); tx <= floorDiv(o.x() + halo, kTile); ++tx)
                tiles[{tx, ty}].push_back(uint32_t(l));
    }
    std::vector<const std::pair<const std::pair<int, int>, std::vector<uint32_t>>*> order;
    for (const auto& t : tiles) order.push_back(&t);
    std::vector<std::unique_ptr<Leaf>> out(leaves.size());
    // One tile per chunk: a cancel stops new tiles, the running sweeps finish (~0.1 s) before
    // Interrupted is thrown (parallelFor lets no exception cut their nested loops short).
    parallelFor(task, order.size(), 1, [&](size_t t) {
        const auto& [key, members] = *order[t];
        auto part = openvdb::FloatGrid::create(in.background());
        part->setTransform(in.transform().copy());
        part->setGridClass(openvdb::GRID_LEVEL_SET);
        for (const uint32_t l : members) part->tree().addLeaf(new Leaf(*leaves[l]));
        // The inside between leaves (a thick stratum's middle) as the whole grid has it; the
        // part's outer edge may read as outside, a false crossing at least the halo away from
        // the tile's own voxels, farther than their band.
        openvdb::tools::signedFloodFill(part->tree());
        // Without the sweep's finalising step: it re-backgrounds the part by its extreme
        // values, which a tile that only grazes the inside (all of it within a rounding of 0)
        // does not have; the band cut below does that job for the whole grid.
        openvdb::tools::FastSweeping<openvdb::FloatGrid> fs;
        openvdb::FloatGrid::Ptr swept;
        if (fs.initSdf(*part, 0.0f, true)) {
            fs.sweep(1, false);
            swept = fs.sdfGrid();
        }
        for (const uint32_t l : members) {
            const openvdb::Coord o = leaves[l]->origin();
            if (floorDiv(o.x(), kTile) != key.first || floorDiv(o.y(), kTile) != key.second) continue;
            const Leaf* r = swept ? swept->tree().probeConstLeaf(o) : nullptr;
            out[l] = std::make_unique<Leaf>(r ? *r : *leaves[l]);
        }
    });
    auto grid = openvdb::FloatGrid::create(in.background());
    grid->setTransform(in.transform().copy());
    for (auto& leaf : out) grid->tree().addLeaf(leaf.release());
    return grid;
}

// The sweeping's distances are first order: OpenVDB's fast sweeping starts from the axis
// crossings next to the surface (exact only where the surface crosses every axis within a
// voxel) and Godunov's scheme spreads their error, so on a 53° wall the grid's normals are off
// by more than 5° at 8.6 % of the voxels (0 % with this; TestWalls). The interpolated field is
// itself the vertical distance to the bilinear surface: over a planar wall φ/|∇φ| (central
// differences of the baked values) is the exact distance. So where that agrees with the swept
// value within half a voxel it is kept, and the swept value elsewhere (at kinks, where ρ
// clamps the field flat, where the field jumps). Depends on each voxel's neighbours only:
// deterministic.
void keepFirstOrderDistance(openvdb::FloatGrid& swept, const openvdb::FloatGrid& raw, Task& task)
{
    const float dx = float(swept.voxelSize()[0]), inv2dx = 0.5f / dx, tol = 0.5f * dx;
    std::vector<openvdb::FloatTree::LeafNodeType*> list;
    swept.tree().getNodes(list);
    parallelFor(task, list.size(), 16, [&](size_t l) {
        openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(raw.tree());
        auto& leaf = *list[l];
        for (auto it = leaf.beginValueOn(); it; ++it) {
            const openvdb::Coord c = it.getCoord();
            bool known = true;
            float v[7];
            const openvdb::Coord at[7] = {c, c.offsetBy(1, 0, 0), c.offsetBy(-1, 0, 0), c.offsetBy(0, 1, 0),
                                          c.offsetBy(0, -1, 0), c.offsetBy(0, 0, 1), c.offsetBy(0, 0, -1)};
            for (int k = 0; k < 7 && known; ++k) known = acc.probeValue(at[k], v[k]);
            if (!known) continue;
            const float gx = (v[1] - v[2]) * inv2dx, gy = (v[3] - v[4]) * inv2dx, gz = (v[5] - v[6]) * inv2dx;
            const float g = std::sqrt(gx * gx + gy * gy + gz * gz);
            if (!(g > 1e-3f)) continue;
            const float d = v[0] / g;
            if (std::abs(d - *it) <= tol) it.setValue(d);
        }
    });
}

} // namespace

FieldPtr convolutionField(std::shared_ptr<const Skeleton> skeleton, double sigma)
{
    return std::make_shared<ConvolutionField>(std::move(skeleton), sigma, 0.0);
}

FieldPtr interpolatedField(std::shared_ptr<const Skeleton> skeleton, double sigma, double reach)
{
    if (!(reach > 0) || !std::isfinite(reach)) fail<ValueError>("arches: reach must be > 0 (got ", reach, ")");
    return std::make_shared<ConvolutionField>(std::move(skeleton), sigma, reach);
}

openvdb::FloatGrid::Ptr bakeSkeleton(const Skeleton& skeleton, const SkeletonBake& settings,
                                     Task& task, BakeStats* stats)
{
    const double dx = settings.voxelSize, sigma = settings.sigma, w = settings.halfWidth;
    if (!(sigma > 0) || !std::isfinite(sigma)) fail<ValueError>("arches: sigma must be > 0 (got ", sigma, ")");
    if (!(dx > 0) || !std::isfinite(dx)) fail<ValueError>("arches: voxel size must be > 0 (got ", dx, ")");
    const bool interpolate = settings.kernel == Kernel::Interpolate;
    // Reach: the band, plus a voxel for the sweeping to start from outside it. (Interpolate's
    // surface lies, like the box's, only where the stacks under the square disagree.)
    const double reach = sigma + (w + 1) * dx;
    task.phase("candidates", 0.1);
    auto candidates = candidateLeaves(skeleton, dx, reach, settings.maxMemoryBytes, task);
    if (settings.box) candidates->tree().clip(*settings.box);

    // Share the skeleton without copying it: the field only lives through this bake.
    std::shared_ptr<const Skeleton> shared(&skeleton, [](const Skeleton*) {});
    auto field = interpolate ? interpolatedField(shared, sigma, settings.reach) : convolutionField(shared, sigma);
    BakeSettings s;
    s.voxelSize = dx;
    // Wide enough that no candidate voxel is clamped (|σ·f| <= σ, |interpolated| <= R): the
    // sweeping needs values.
    s.halfWidth = std::max(w, (interpolate ? settings.reach : sigma) / dx + 2.0);
    s.renormalize = Renormalize::Off;
    s.candidates = candidates;
    s.maxMemoryBytes = settings.maxMemoryBytes;
    task.phase("convolution", 0.5);
    BakeResult r = bake(*field, s, task.interrupter());
    if (stats) *stats = r.stats;

    task.phase("redistance", 0.4);
    task.check();
    // Sweep only the voxels that can end in the band: those within w + 1 voxels (Chebyshev) of
    // a sign change. The candidate leaves hold ~2x as many (whole leaves, σ of slack).
    {
        auto crossing = openvdb::MaskGrid::create(false);
        const auto& tree = r.surface->tree();
        std::vector<const openvdb::FloatTree::LeafNodeType*> list;
        tree.getNodes(list);
        std::vector<std::vector<openvdb::Coord>> marks(list.size());
        parallelFor(task, list.size(), 16, [&](size_t l) {
            openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(tree);
            for (auto it = list[l]->cbeginValueOn(); it; ++it) {
                const bool in = *it < 0;
                const openvdb::Coord c = it.getCoord();
                if ((acc.getValue(c.offsetBy(1, 0, 0)) < 0) != in || (acc.getValue(c.offsetBy(-1, 0, 0)) < 0) != in ||
                    (acc.getValue(c.offsetBy(0, 1, 0)) < 0) != in || (acc.getValue(c.offsetBy(0, -1, 0)) < 0) != in ||
                    (acc.getValue(c.offsetBy(0, 0, 1)) < 0) != in || (acc.getValue(c.offsetBy(0, 0, -1)) < 0) != in) {
                    marks[l].push_back(c);
                }
            }
        });
        auto macc = crossing->getAccessor();
        for (const auto& m : marks)
            for (const auto& c : m) macc.setValueOn(c);
        openvdb::tools::dilateActiveValues(crossing->tree(), int(std::ceil(w)) + 1, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                           openvdb::tools::IGNORE_TILES);
        r.surface->tree().topologyIntersection(crossing->tree());
    }
    task.check();
    openvdb::FloatGrid::Ptr grid = sweepTiled(*r.surface, w, task);
    task.check();
    if (interpolate) keepFirstOrderDistance(*grid, *r.surface, task);
    // The band: |φ| < w·dx active, the rest off at ±background.
    const float bg = float(w * dx);
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(grid->tree());
    leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, size_t) {
        for (auto it = leaf.beginValueOn(); it; ++it) {
            if (std::abs(*it) >= bg) leaf.setValueOff(it.pos(), *it < 0 ? -bg : bg);
        }
    });
    openvdb::tools::changeLevelSetBackground(grid->tree(), bg);
    openvdb::tools::pruneLevelSet(grid->tree());
    openvdb::tools::signedFloodFill(grid->tree());
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    return grid;
}

openvdb::FloatGrid::Ptr materialGrid(const Stacks& stacks, MaterialMask mask, double sigma,
                                     const openvdb::FloatGrid& surface, Task& task)
{
    std::vector<Skeleton> skeletons;
    std::vector<Material> which;
    for (int m = 0; m < kMaterialCount; ++m) {
        if (!(mask & maskOf(Material(m)))) continue;
        skeletons.emplace_back(stacks, maskOf(Material(m)));
        which.push_back(Material(m));
    }
    std::vector<std::pair<Material, const Skeleton*>> parts;
    for (size_t k = 0; k < skeletons.size(); ++k) parts.emplace_back(which[k], &skeletons[k]);
    return materialGrid(parts, sigma, surface, task);
}

openvdb::FloatGrid::Ptr materialGrid(const std::vector<std::pair<Material, const Skeleton*>>& parts,
                                     double sigma, const openvdb::FloatGrid& surface, Task& task)
{
    auto ids = openvdb::FloatGrid::create(-1.0f);
    ids->setTransform(surface.transform().copy());
    ids->setName("material");
    ids->setGridClass(openvdb::GRID_UNKNOWN);
    ids->tree().topologyUnion(surface.tree());
    // Inside tiles are not material voxels: keep only the leaves' active voxels.
    openvdb::tools::pruneInactive(ids->tree());
    const auto& xf = surface.transform();
    const double h0 = 0.5 * xf.voxelSize()[0];
    std::vector<openvdb::FloatTree::LeafNodeType*> list;
    ids->tree().getNodes(list);
    // The material with the most volume in the cube of half size h (ties to the lower id), and
    // that cube's share of material.
    auto vote = [&](const Vec3d& q, double h, double& share) {
        double bestV = -1, total = 0;
        float id = -1.0f;
        for (const auto& [m, sk] : parts) {
            const double v = sk->volume(q, h);
            total += v;
            if (v > bestV) {
                bestV = v;
                id = float(unsigned(m));
            }
        }
        share = total / (8 * h * h * h);
        return id;
    };
    parallelFor(task, list.size(), 8, [&](size_t l) {
        auto& leaf = *list[l];
        const auto* phiLeaf = surface.tree().probeConstLeaf(leaf.origin());
        auto acc = surface.getConstAccessor();
        for (auto it = leaf.beginValueOn(); it; ++it) {
            const openvdb::Coord c = it.getCoord();
            const Vec3d p = xf.indexToWorld(c);
            const double phi = phiLeaf ? double(phiLeaf->getValue(it.pos())) : 0.0;
            const double reach = sigma + std::abs(phi);
            // The layer that is there: from the surface point nearest to p (p − φ n), cubes
            // of half size h = voxel/2, 1, 2 … voxels just under the surface (centred h deep
            // along −n), the first at least half full of material. A volume vote round p
            // (the former rule, half size σ + |φ|) would give a layer thinner than σ to the
            // material beneath it: a 0.3 m sand cover with σ = 0.6 m came out as bedrock.
            Vec3d g(0.0);
            for (int a = 0; a < 3; ++a) {
                openvdb::Coord u = c, d = c;
                u[a] += 1;
                d[a] -= 1;
                g[a] = double(acc.getValue(u)) - double(acc.getValue(d));
            }
            float id = -1.0f;
            double share = 0;
            if (g.length() > 1e-6) {
                const Vec3d n = g.unit();
                const Vec3d surfacePoint = p - n * phi;
                for (double h = h0; h <= reach && id < 0; h *= 2) {
                    const float pick = vote(surfacePoint - n * h, h, share);
                    if (share >= 0.5) id = pick;
                }
            }
            if (id < 0) id = vote(p, reach, share); // no clear layer under the surface
            leaf.setValueOnly(it.pos(), id);
        }
    });
    return ids;
}

} // namespace arches
} // namespace rockvdb
