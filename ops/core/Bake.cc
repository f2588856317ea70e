// SPDX-License-Identifier: Apache-2.0
#include "Bake.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridUtil.h>

#include <openvdb/tools/LevelSetTracker.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <unistd.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace rockvdb {

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;
using FloatTree = openvdb::FloatTree;
using LeafT = FloatTree::LeafNodeType;
using Node2T = FloatTree::RootNodeType::ChildNodeType;
using Node1T = Node2T::ChildNodeType;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0)
{
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

constexpr int kLeafDim = 8;
constexpr int kLeafVoxels = 512;
constexpr int kPadDim = 10; // leaf plus a one-voxel apron for central differences

// Bytes per active voxel of a narrow band: 4 B value in partly filled leaves (~60% active)
// plus masks, node tables and the attribute grid when present.
constexpr double kBytesPerActive = 8.0;
constexpr double kBytesPerLeaf = sizeof(LeafT) + 96;

struct Domain
{
    CoordBBox box;      // voxels that may become active (inclusive)
    CoordBBox whole;    // box of the whole bake (box is one chunk of it, or the same)
    double bandField;   // |f| threshold for candidate leaves (field units)
    const Field* field;
    // ω'(r) = max(r, ω(r)): how far |f| can change over a distance r (Field::modulus).
    double modulus(double r) const { return std::max(r, field->modulus(r)); }
    float background;
    bool renormalize;
};

Domain makeDomain(const Field& field, const BakeSettings& s)
{
    Domain d;
    const double dx = s.voxelSize;
    // Never below halfWidth·dx after rounding to float (OpenVDB's checkLevelSet compares the
    // background with 3 voxels in double precision).
    d.background = float(s.halfWidth * dx);
    if (double(d.background) < s.halfWidth * dx) {
        d.background = std::nextafter(d.background, std::numeric_limits<float>::infinity());
    }
    d.renormalize = s.renormalize == Renormalize::On ||
                    (s.renormalize == Renormalize::Auto && !field.exact());
    const double bandScale = d.renormalize ? s.renormBandScale : 1.0;
    d.field = &field;
    // Band in field units: voxels within distance band·bandScale have |f| <= ω'(that).
    d.bandField = d.renormalize ? d.modulus(double(d.background) * bandScale)
                                : double(d.background);

    BBoxd world = field.bounds();
    const bool bounded = isBounded(world);
    if (!bounded && !s.region) {
        double reach = 0;
        bool finite = true;
        for (int a = 0; a < 3; ++a) {
            finite = finite && std::isfinite(world.min()[a]) && std::isfinite(world.max()[a]);
            reach = std::max({reach, std::abs(world.min()[a]), std::abs(world.max()[a])});
        }
        if (finite && reach < 1e300) {
            fail<ValueError>("bake: the field's bounds reach ", reach, " m from the origin (more "
                             "than 1e15 m: no voxel grid spans that); make it smaller or give a region");
        }
        fail<ValueError>("bake: the field is unbounded (a plane or half-space); give a region");
    }
    if (bounded) world.expand(double(d.background) * bandScale + 2 * dx);
    CoordBBox box;
    if (bounded) {
        box = CoordBBox(Coord(int(std::floor(std::max(world.min()[0] / dx, -1e9))),
                              int(std::floor(std::max(world.min()[1] / dx, -1e9))),
                              int(std::floor(std::max(world.min()[2] / dx, -1e9)))),
                        Coord(int(std::ceil(std::min(world.max()[0] / dx, 1e9))),
                              int(std::ceil(std::min(world.max()[1] / dx, 1e9))),
                              int(std::ceil(std::min(world.max()[2] / dx, 1e9)))));
    }
    if (s.region) {
        // Half-open on voxel centres: index i is inside iff min <= i·dx < max.
        const BBoxd& r = *s.region;
        const double tol = 1e-9;
        Coord lo, hi;
        for (int a = 0; a < 3; ++a) {
            const double l = std::ceil(r.min()[a] / dx - tol);
            const double h = std::ceil(r.max()[a] / dx - tol) - 1;
            if (std::abs(l) > 1e9 || std::abs(h) > 1e9) {
                fail<ValueError>("bake: region is too large for voxel size ", dx,
                                 " (more than 1e9 voxels along an axis)");
            }
            lo[a] = int(l);
            hi[a] = int(h);
        }
        const CoordBBox rbox(lo, hi);
        box = bounded ? CoordBBox(Coord::maxComponent(box.min(), rbox.min()),
                                  Coord::minComponent(box.max(), rbox.max()))
                      : rbox;
    }
    d.whole = box;
    if (s.chunk.active() && !box.empty()) {
        box = chunkBox(box, chunkDims(s.chunk, box), s.chunk.index);
    }
    d.box = box;
    return d;
}

// A node of the culling hierarchy: voxels [origin, origin + size - 1].
struct Node
{
    Coord origin;
    int size;
};

class Baker
{
public:
    Baker(const Field& f, const BakeSettings& s, const Domain& d,
          openvdb::util::NullInterrupter* interrupt)
        : mField(f), mS(s), mD(d), mDx(float(s.voxelSize)), mInterrupt(interrupt)
    {
        // Values at or beyond this magnitude all end up as ±background: without
        // renormalisation that is the background itself; with it, a voxel in the band reads
        // neighbours up to L·(band + 1 voxel) away in field units.
        mClampBand = d.renormalize
            ? float(d.modulus(double(d.background) * s.renormBandScale + s.voxelSize) * 1.01)
            : d.background;
        // As a distance: the band the voxels need (widened when renormalising) plus a voxel,
        // doubled to cover smooth blends that read neighbours' values beyond it.
        mReach = float(2.0 * (double(d.background) * (d.renormalize ? s.renormBandScale : 1.0) +
                              s.voxelSize));
        mInvSlope = float(1.0 / std::max(1.0, f.lipschitz()));
    }

    BakeResult run()
    {
        BakeResult result;
        const auto t0 = Clock::now();
        std::vector<Coord> candidates = cull();
        result.stats.candidateLeaves = candidates.size();
        result.stats.cullSeconds = since(t0);
        checkInterrupt(10);

        const auto t1 = Clock::now();
        std::vector<LeafT*> leaves(candidates.size(), nullptr);
        std::vector<LeafT*> attrs(mS.withAttribute ? candidates.size() : 0, nullptr);
        fill(candidates, leaves, attrs);
        result.stats.fillSeconds = since(t1);

        const auto t2 = Clock::now();
        auto xform = openvdb::math::Transform::createLinearTransform(mS.voxelSize);
        auto surface = emptyLevelSet(mS.gridName, xform, mD.background);
        FloatGrid::Ptr attribute;
        if (mS.withAttribute) attribute = emptyAttribute(mS.attributeName, xform, kNoId);
        FloatTree& tree = surface->tree();
        std::vector<Node1T*> nodes1;
        std::vector<Node2T*> nodes2;
        result.stats.leaves = assemble(candidates, leaves, tree, mD.background, nodes1, nodes2);
        if (attribute) {
            std::vector<Node1T*> a1;
            std::vector<Node2T*> a2;
            assemble(candidates, attrs, attribute->tree(), kNoId, a1, a2);
        }
        if (mNaN.load()) {
            fail<ValueError>("bake: the field produced NaN values (first near leaf ",
                             mNaNLeaf, "); check the field's parameters");
        }
        // Leaves are already sign-filled (inactive voxels hold ±background with the field's
        // own sign), so the flood fill only classifies the tiles of the nodes built above,
        // bottom-up, with OpenVDB's own operator (tools::signedFloodFill at minLevel 1,
        // without a NodeManager pass over every leaf).
        {
            const openvdb::tools::SignedFloodFillOp<FloatTree> op(tree, /*minLevel=*/1);
            tbb::parallel_for(tbb::blocked_range<size_t>(0, nodes1.size(), 1),
                [&](const tbb::blocked_range<size_t>& r) {
                    for (size_t i = r.begin(); i != r.end(); ++i) op(*nodes1[i]);
                });
            tbb::parallel_for(tbb::blocked_range<size_t>(0, nodes2.size(), 1),
                [&](const tbb::blocked_range<size_t>& r) {
                    for (size_t i = r.begin(); i != r.end(); ++i) op(*nodes2[i]);
                });
            op(tree.root());
        }
        if (mS.trackerSteps > 0 && result.stats.leaves > 0) {
            openvdb::tools::LevelSetTracker<FloatGrid> tracker(*surface);
            tracker.setNormCount(mS.trackerSteps);
            // First-order upwind (FIRST_BIAS, TVD_RK1) instead of the default WENO5 / RK2: on
            // the demo's detailed cliff the band comes out as eikonal (86.8 % of it within
            // 20 % of |∇φ| = 1 against 85.6 %), no voxel changes sign, values move 0.02 voxel
            // on average, and three steps take 1.3 s instead of 5.0 s.
            tracker.setSpatialScheme(openvdb::math::FIRST_BIAS);
            tracker.setTemporalScheme(openvdb::math::TVD_RK1);
            tracker.normalize();
            // Normalisation moves values across ±background: those voxels leave the band.
            tracker.prune();
            if (attribute) {
                // The tracker keeps the active topology; refresh ids only where both agree.
                attribute->tree().topologyIntersection(tree);
            }
        }
        result.stats.activeVoxels = mS.trackerSteps > 0 ? size_t(tree.activeVoxelCount())
                                                         : mActive.load();
        result.stats.fieldEvaluations = mEvals.load();
        result.stats.renormalized = mD.renormalize;
        result.stats.finishSeconds = since(t2);
        result.surface = surface;
        result.attribute = attribute;
        return result;
    }

private:
    void checkInterrupt(int percent)
    {
        if (mCancel.load(std::memory_order_relaxed)) throw Interrupted();
        if (mInterrupt && mInterrupt->wasInterrupted(percent)) throw Interrupted();
    }

    bool pollInterrupt(int percent)
    {
        if (mCancel.load(std::memory_order_relaxed)) return true;
        if (mInterrupt && mInterrupt->wasInterrupted(percent)) {
            mCancel.store(true);
            return true;
        }
        return false;
    }

    // ---- 1. hierarchical culling -------------------------------------------------------

    std::vector<Coord> cull()
    {
        const CoordBBox& box = mD.box;
        if (box.empty()) return {};
        if (mCandidates) return candidateLeaves();
        // Top nodes: the smallest power of two >= 8 giving at most ~512 of them (enough tasks
        // for the threads; fewer would cost more evaluations, more would cost task overhead).
        int top = kLeafDim;
        auto count = [&](int size) {
            double n = 1;
            for (int a = 0; a < 3; ++a) {
                n *= double(floorDiv(box.max()[a], size) - floorDiv(box.min()[a], size) + 1);
            }
            return n;
        };
        while (count(top) > 512 && top < (1 << 20)) top *= 2;
        std::vector<Node> tops;
        const Coord lo(floorDiv(box.min()[0], top) * top, floorDiv(box.min()[1], top) * top,
                       floorDiv(box.min()[2], top) * top);
        for (int i = lo[0]; i <= box.max()[0]; i += top)
            for (int j = lo[1]; j <= box.max()[1]; j += top)
                for (int k = lo[2]; k <= box.max()[2]; k += top)
                    tops.push_back({Coord(i, j, k), top});
        // Depth-first visits keep each Node1T's (128³) candidates contiguous when the tops
        // are ordered by the Node1T that holds them (a top larger than 128 holds whole ones).
        std::stable_sort(tops.begin(), tops.end(), [](const Node& a, const Node& b) {
            return node1Origin(a.origin) < node1Origin(b.origin);
        });

        std::vector<std::vector<Coord>> perTop(tops.size());
        std::atomic<size_t> total{0};
        const double limit = memoryLimit();
        // Shared counters are touched once per top, never per node: contended atomics cost
        // more than the culling itself at 2 threads.
        tbb::parallel_for(tbb::blocked_range<size_t>(0, tops.size(), 1),
            [&](const tbb::blocked_range<size_t>& r) {
                for (size_t t = r.begin(); t != r.end(); ++t) {
                    if (pollInterrupt(int(10.0 * double(t) / double(tops.size())))) return;
                    std::vector<Coord> found;
                    size_t evals = 0;
                    visit(tops[t], found, evals);
                    mEvals.fetch_add(evals, std::memory_order_relaxed);
                    perTop[t] = std::move(found);
                    const size_t n = total.fetch_add(perTop[t].size()) + perTop[t].size();
                    if (double(n) * (kBytesPerLeaf + kLeafVoxels * 4.0) > limit) {
                        mOverflow.store(true);
                        mCancel.store(true);
                        return;
                    }
                }
            });
        if (mOverflow.load()) {
            fail<ValueError>("bake: the narrow band needs more than ", formatBytes(limit),
                             " (over ", total.load(), " leaves); use a larger voxel size or a "
                             "smaller region");
        }
        checkInterrupt(10);
        std::vector<Coord> out;
        out.reserve(total.load());
        for (auto& v : perTop) out.insert(out.end(), v.begin(), v.end());
        return out;
    }

    // The candidate mask's leaves (and the leaves of its active tiles) in the domain: the
    // caller's bound replaces the field's culling, which would only test the same leaves
    // again (a leaf without band voxels comes out empty and is dropped either way).
    std::vector<Coord> candidateLeaves()
    {
        const CoordBBox& box = mD.box;
        std::vector<Coord> out;
        for (auto it = mCandidates->cbeginLeaf(); it; ++it) {
            const CoordBBox lb(it->origin(), it->origin().offsetBy(kLeafDim - 1));
            if (lb.hasOverlap(box)) out.push_back(it->origin());
        }
        auto tiles = mCandidates->cbeginValueOn();
        tiles.setMaxDepth(openvdb::MaskTree::ValueOnCIter::LEAF_DEPTH - 1);
        for (; tiles; ++tiles) {
            CoordBBox tb;
            tiles.getBoundingBox(tb);
            tb.intersect(box);
            if (tb.empty()) continue;
            const Coord lo = tb.min() & ~(kLeafDim - 1);
            for (int i = lo[0]; i <= tb.max()[0]; i += kLeafDim)
                for (int j = lo[1]; j <= tb.max()[1]; j += kLeafDim)
                    for (int k = lo[2]; k <= tb.max()[2]; k += kLeafDim) out.emplace_back(i, j, k);
        }
        // Grouped by their level-1 node, as assemble() wants, and in Morton order inside it
        // (the culling's depth-first order: neighbouring leaves read neighbouring inputs).
        auto morton = [](const Coord& c) {
            unsigned m = 0;
            for (int b = 0; b < 4; ++b) {
                for (int a = 0; a < 3; ++a) m |= unsigned((c[a] >> (3 + b)) & 1) << (3 * b + 2 - a);
            }
            return m;
        };
        std::sort(out.begin(), out.end(), [&](const Coord& a, const Coord& b) {
            const Coord na = node1Origin(a), nb = node1Origin(b);
            return na != nb ? na < nb : morton(a) < morton(b);
        });
        const double limit = memoryLimit();
        if (double(out.size()) * (kBytesPerLeaf + kLeafVoxels * 4.0) > limit) {
            fail<ValueError>("bake: the narrow band needs more than ", formatBytes(limit),
                             " (over ", out.size(), " leaves); use a larger voxel size or a "
                             "smaller region");
        }
        return out;
    }

    bool overlaps(const Node& n) const
    {
        const CoordBBox nb(n.origin, n.origin.offsetBy(n.size - 1));
        return nb.hasOverlap(mD.box);
    }

    Vec3f centre(const Node& n) const
    {
        const double half = 0.5 * double(n.size - 1);
        return Vec3f(float((n.origin[0] + half) * mS.voxelSize),
                     float((n.origin[1] + half) * mS.voxelSize),
                     float((n.origin[2] + half) * mS.voxelSize));
    }

    // A node may hold band voxels unless |f(centre)| exceeds ω'(half diagonal) + band;
    // 1% and half a voxel of slack absorb float rounding in the field.
    bool mayHoldBand(float v, int size) const
    {
        const double halfDiag = 0.5 * double(size - 1) * std::sqrt(3.0) * mS.voxelSize;
        return std::abs(double(v)) <=
               (mD.modulus(halfDiag) + mD.bandField) * 1.01 + 0.5 * mS.voxelSize;
    }

    void visit(const Node& n, std::vector<Coord>& out, size_t& evals)
    {
        if (!overlaps(n)) return;
        const float v = mField.eval(Vec3d(centre(n)));
        ++evals;
        if (mayHoldBand(v, n.size)) descend(n, out, evals);
    }

    // n may hold band voxels: test its eight children with one batch (exact values, no
    // band hints: the test needs |f| well beyond the band) and recurse depth-first.
    void descend(const Node& n, std::vector<Coord>& out, size_t& evals)
    {
        if (n.size == kLeafDim) {
            out.push_back(n.origin);
            return;
        }
        const int h = n.size / 2;
        Node kids[8];
        float x[8], y[8], z[8], v[8];
        int m = 0;
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j)
                for (int k = 0; k < 2; ++k) {
                    const Node c{n.origin.offsetBy(i * h, j * h, k * h), h};
                    if (!overlaps(c)) continue;
                    const Vec3f p = centre(c);
                    kids[m] = c;
                    x[m] = p[0];
                    y[m] = p[1];
                    z[m] = p[2];
                    ++m;
                }
        if (m == 0) return;
        Batch b{x, y, z, m, centre(n), float(0.5 * n.size * std::sqrt(3.0) * mS.voxelSize)};
        mField.evalBatch(b, v);
        evals += size_t(m);
        for (int q = 0; q < m; ++q) {
            if (mayHoldBand(v[q], h)) descend(kids[q], out, evals);
        }
    }

    // ---- 3. tree assembly --------------------------------------------------------------

    static Coord node1Origin(const Coord& c) { return c & ~(Node1T::DIM - 1); }

    // Candidates come grouped by their level-1 internal node (128³ voxels; see cull()).
    // Each group becomes one Node1T built in parallel; only the few Node1 → Node2 → root
    // links are made serially. The tree does not depend on the order of either step.
    static size_t assemble(const std::vector<Coord>& cand, std::vector<LeafT*>& leaves,
                           FloatTree& tree, float background, std::vector<Node1T*>& nodes1,
                           std::vector<Node2T*>& nodes2)
    {
        std::vector<size_t> starts;
        for (size_t i = 0; i < cand.size(); ++i) {
            if (i == 0 || node1Origin(cand[i]) != node1Origin(cand[i - 1])) starts.push_back(i);
        }
        starts.push_back(cand.size());
        const size_t groups = starts.size() - 1;
        std::vector<Node1T*> nodes(groups, nullptr);
        std::atomic<size_t> count{0};
        tbb::parallel_for(tbb::blocked_range<size_t>(0, groups, 1),
            [&](const tbb::blocked_range<size_t>& r) {
                for (size_t g = r.begin(); g != r.end(); ++g) {
                    Node1T* node = nullptr;
                    size_t n = 0;
                    for (size_t i = starts[g]; i != starts[g + 1]; ++i) {
                        if (!leaves[i]) continue;
                        if (!node) node = new Node1T(node1Origin(cand[i]), background, false);
                        node->addLeaf(leaves[i]);
                        leaves[i] = nullptr;
                        ++n;
                    }
                    nodes[g] = node;
                    count.fetch_add(n, std::memory_order_relaxed);
                }
            });
        auto& root = tree.root();
        for (Node1T* node : nodes) {
            if (!node) continue;
            Node2T* parent = root.template probeNode<Node2T>(node->origin());
            if (!parent) {
                parent = new Node2T(node->origin() & ~(Node2T::DIM - 1), background, false);
                root.addChild(parent);
                nodes2.push_back(parent);
            }
            parent->addChild(node);
            nodes1.push_back(node);
        }
        return count.load();
    }

    // ---- 2. leaf filling ----------------------------------------------------------------

    void fill(const std::vector<Coord>& cand, std::vector<LeafT*>& leaves,
              std::vector<LeafT*>& attrs)
    {
        const size_t n = cand.size();
        std::atomic<size_t> done{0};
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16),
            [&](const tbb::blocked_range<size_t>& r) {
                const int pct = 10 + int(85.0 * double(done.load()) / double(std::max<size_t>(n, 1)));
                if (pollInterrupt(pct)) return;
                Scratch scratch;
                for (size_t i = r.begin(); i != r.end(); ++i) {
                    fillLeaf(cand[i], scratch, leaves[i], attrs.empty() ? nullptr : &attrs[i]);
                }
#if defined(__SSE2__)
                _mm_sfence();
#endif
                mEvals.fetch_add(scratch.evals, std::memory_order_relaxed);
                mActive.fetch_add(scratch.active, std::memory_order_relaxed);
                done.fetch_add(r.size(), std::memory_order_relaxed);
            });
        if (mCancel.load()) {
            for (auto* l : leaves) delete l;
            for (auto* l : attrs) delete l;
            throw Interrupted();
        }
    }

    struct Scratch
    {
        BatchBuffer pts;
        alignas(64) float val[2 * kMaxBatch]; // a padded block, then a masked batch's values
        alignas(64) float id[kMaxBatch];
        alignas(64) float out[kLeafVoxels];
        alignas(64) float outId[kLeafVoxels];
        size_t evals = 0;  // per task, added to the shared counters once
        size_t active = 0;
    };

    // Voxel positions of a dim³ block starting at `origin`, laid out x-major like
    // LeafNode::coordToOffset (n = (x·dim + y)·dim + z). Written from per-axis tables so the
    // stores vectorise; float(o) + float(k) == float(o + k) for |o + k| < 2^24, so a voxel
    // gets the same position whichever block computes it.
    template<int Dim>
    static void positions(const Coord& origin, int start, float dx, float* __restrict x,
                          float* __restrict y, float* __restrict z)
    {
        float ax[Dim], ay[Dim], az[Dim];
        for (int k = 0; k < Dim; ++k) {
            ax[k] = (float(origin[0]) + float(start + k)) * dx;
            ay[k] = (float(origin[1]) + float(start + k)) * dx;
            az[k] = (float(origin[2]) + float(start + k)) * dx;
        }
        for (int i = 0; i < Dim; ++i) {
            for (int j = 0; j < Dim; ++j) {
                const int row = (i * Dim + j) * Dim;
                for (int k = 0; k < Dim; ++k) {
                    x[row + k] = ax[i];
                    y[row + k] = ay[j];
                    z[row + k] = az[k];
                }
            }
        }
    }

    // Copy a leaf's values into its freshly allocated buffer. Non-temporal stores skip the
    // read-for-ownership of memory that is only written here (the band is far larger than
    // the caches); the fence in fill() orders them before the tree is assembled.
    static void streamCopy(const float* __restrict src, float* __restrict dst)
    {
#if defined(__SSE2__)
        if ((reinterpret_cast<uintptr_t>(dst) & 15) == 0) {
            for (int i = 0; i < kLeafVoxels; i += 4) _mm_stream_ps(dst + i, _mm_load_ps(src + i));
            return;
        }
#endif
        std::copy(src, src + kLeafVoxels, dst);
    }

    // Clamp v to [-bg, bg] in place; bit n of words is set where |v| < bg (active).
    // Returns true when some value is NaN.
    static bool clampAndMask(float* __restrict v, float bg, uint64_t* words)
    {
#if defined(__SSE2__)
        const __m128 hi = _mm_set1_ps(bg), lo = _mm_set1_ps(-bg);
        const __m128 absMask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
        __m128 nan = _mm_setzero_ps();
        for (int w = 0; w < kLeafVoxels / 64; ++w) {
            uint64_t word = 0;
            for (int q = 0; q < 16; ++q) {
                float* p = v + w * 64 + q * 4;
                const __m128 x = _mm_loadu_ps(p);
                nan = _mm_or_ps(nan, _mm_cmpunord_ps(x, x));
                const __m128 c = _mm_min_ps(_mm_max_ps(x, lo), hi);
                _mm_storeu_ps(p, c);
                const __m128 active = _mm_cmplt_ps(_mm_and_ps(c, absMask), hi);
                word |= uint64_t(_mm_movemask_ps(active)) << (q * 4);
            }
            words[w] = word;
        }
        return _mm_movemask_ps(nan) != 0;
#else
        bool nan = false;
        for (int w = 0; w < kLeafVoxels / 64; ++w) {
            uint64_t word = 0;
            for (int b = 0; b < 64; ++b) {
                float& x = v[w * 64 + b];
                nan |= std::isnan(x);
                x = std::min(std::max(x, -bg), bg);
                word |= uint64_t(std::abs(x) < bg) << b;
            }
            words[w] = word;
        }
        return nan;
#endif
    }

    // Index in the padded 10³ block of leaf voxel n (x-major, like LeafNode::coordToOffset).
    static int padIndex(int n)
    {
        return ((n >> 6) + 1) * 100 + (((n >> 3) & 7) + 1) * 10 + (n & 7) + 1;
    }

    // The renormalised value at padded index p from the values around it.
    float renormalized(const float* val, int p) const
    {
        const float inv2dx = 0.5f / mDx;
        const float gx = (val[p + 100] - val[p - 100]) * inv2dx;
        const float gy = (val[p + 10] - val[p - 10]) * inv2dx;
        const float gz = (val[p + 1] - val[p - 1]) * inv2dx;
        const float g = std::sqrt(gx * gx + gy * gy + gz * gz);
        // f/|∇f|: first-order distance; |∇f| ~ 0 only far from the surface. An L-Lipschitz f
        // bounds the distance below by |f|/L: where f jumps (a lower bound switching formula)
        // |∇f| is huge and f/|∇f| would fake a surface. At |f| >= mClampBand the voxel is
        // farther than the band from the surface (that is what the clamp band means): it
        // stays out, whatever its neighbours (values beyond the band are only bounds, and
        // may jump).
        const float v = val[p];
        const float r = g > 1e-6f ? v / g : v;
        return std::abs(v) >= mClampBand ? v
             : std::abs(r) >= std::abs(v) * mInvSlope ? r
                                                      : v * mInvSlope;
    }

    // The candidate voxel mask's voxels of the leaf at `origin` (a tile of it: all), and
    // with renormalisation their six neighbours, evaluated in one batch; the voxels it leaves
    // off hold ±background with the sign of mSigns there. Each value is the same as a full
    // leaf's would be: batches are independent per point, and a point's position does not
    // depend on the batch that holds it.
    void fillMasked(const Coord& origin, Scratch& s, bool withId)
    {
        const float dx = mDx;
        const float bg = mD.background;
        const auto* c = mCandidates->probeConstLeaf(origin);
        openvdb::MaskTree::LeafNodeType::NodeMaskType on;
        if (c) on = c->getValueMask();
        else on.setOn();
        // Signs of the voxels left off.
        if (const LeafT* sl = mSigns->probeConstLeaf(origin)) {
            const float* sv = sl->buffer().data();
            for (int n = 0; n < kLeafVoxels; ++n) s.out[n] = sv[n] < 0 ? -bg : bg;
        } else {
            const float v = mSigns->getValue(origin) < 0 ? -bg : bg;
            std::fill(s.out, s.out + kLeafVoxels, v);
        }
        if (withId) std::fill(s.outId, s.outId + kLeafVoxels, kNoId);
        if (on.isOff()) return;
        const bool renorm = mD.renormalize;
        const int dim = renorm ? kPadDim : kLeafDim;
        const int start = renorm ? -1 : 0;
        bool need[kPadDim * kPadDim * kPadDim] = {};
        for (auto it = on.beginOn(); it; ++it) {
            const int n = int(it.pos());
            if (!renorm) {
                need[n] = true;
                continue;
            }
            const int p = padIndex(n);
            need[p] = need[p - 1] = need[p + 1] = need[p - 10] = need[p + 10] = need[p - 100] =
                need[p + 100] = true;
        }
        // The same positions as positions<dim>(origin, start, ...) gives.
        int m = 0, idx[kPadDim * kPadDim * kPadDim];
        for (int i = 0; i < dim; ++i) {
            const float x = (float(origin[0]) + float(start + i)) * dx;
            for (int j = 0; j < dim; ++j) {
                const float y = (float(origin[1]) + float(start + j)) * dx;
                for (int k = 0; k < dim; ++k) {
                    const int p = (i * dim + j) * dim + k;
                    if (!need[p]) continue;
                    s.pts.x[m] = x;
                    s.pts.y[m] = y;
                    s.pts.z[m] = (float(origin[2]) + float(start + k)) * dx;
                    idx[m++] = p;
                }
            }
        }
        s.pts.n = m;
        s.pts.radius = (renorm ? 4.5f : 3.5f) * 1.7320508f * dx;
        float* vals = s.val;
        float* ids = s.id;
        if (withId) mField.evalIdBatch(s.pts.view(), vals + kPadDim * kPadDim * kPadDim, ids);
        else mField.evalBatch(s.pts.view(), vals + kPadDim * kPadDim * kPadDim);
        s.evals += size_t(m);
        // Scatter into the block (values of points not needed are never read).
        const float* got = vals + kPadDim * kPadDim * kPadDim;
        float idAt[kPadDim * kPadDim * kPadDim];
        for (int q = 0; q < m; ++q) {
            vals[idx[q]] = got[q];
            if (withId) idAt[idx[q]] = ids[q];
        }
        for (auto it = on.beginOn(); it; ++it) {
            const int n = int(it.pos());
            const int p = renorm ? padIndex(n) : n;
            s.out[n] = renorm ? renormalized(vals, p) : vals[p];
            if (withId) s.outId[n] = idAt[p];
        }
    }

    void fillLeaf(const Coord& origin, Scratch& s, LeafT*& leafOut, LeafT** attrOut)
    {
        const float dx = mDx;
        const bool withId = attrOut != nullptr;
        s.pts.center = Vec3f(float(origin[0] + 3.5) * dx, float(origin[1] + 3.5) * dx,
                             float(origin[2] + 3.5) * dx);
        s.pts.band = mClampBand;
        s.pts.reach = mReach;
        if (mSigns) {
            fillMasked(origin, s, withId);
        } else if (!mD.renormalize) {
            positions<kLeafDim>(origin, 0, dx, s.pts.x, s.pts.y, s.pts.z);
            s.pts.n = kLeafVoxels;
            s.pts.radius = 3.5f * 1.7320508f * dx;
            if (withId) mField.evalIdBatch(s.pts.view(), s.out, s.outId);
            else mField.evalBatch(s.pts.view(), s.out);
            s.evals += kLeafVoxels;
        } else {
            const int np = kPadDim * kPadDim * kPadDim;
            positions<kPadDim>(origin, -1, dx, s.pts.x, s.pts.y, s.pts.z);
            s.pts.n = np;
            s.pts.radius = 4.5f * 1.7320508f * dx;
            if (withId) mField.evalIdBatch(s.pts.view(), s.val, s.id);
            else mField.evalBatch(s.pts.view(), s.val);
            s.evals += size_t(np);
            for (int n = 0; n < kLeafVoxels; ++n) {
                const int p = padIndex(n);
                s.out[n] = renormalized(s.val, p);
                if (withId) s.outId[n] = s.id[p];
            }
        }
        const float bg = mD.background;
        uint64_t words[kLeafVoxels / 64];
        const bool nan = clampAndMask(s.out, bg, words);
        uint64_t any = 0;
        for (auto w : words) any |= w;
        // Voxels outside a region clip are inactive and hold ±background like every other
        // inactive voxel (the sign stays the field's).
        if (any && !mD.box.isInside(CoordBBox(origin, origin.offsetBy(kLeafDim - 1)))) {
            any = 0;
            for (int n = 0; n < kLeafVoxels; ++n) {
                const Coord ijk = origin.offsetBy(n >> 6, (n >> 3) & 7, n & 7);
                if (!mD.box.isInside(ijk)) {
                    words[n >> 6] &= ~(uint64_t(1) << (n & 63));
                    s.out[n] = s.out[n] < 0 ? -bg : bg;
                }
            }
            for (auto w : words) any |= w;
        }
        if (nan && !mNaN.exchange(true)) mNaNLeaf = origin;
        if (!any) return;

        for (auto w : words) s.active += size_t(__builtin_popcountll(w));
        // PartialCreate + allocate: the buffer is written once, never pre-filled.
        auto* leaf = new LeafT(openvdb::PartialCreate(), origin, bg);
        leaf->buffer().allocate();
        streamCopy(s.out, leaf->buffer().data());
        auto& mask = leaf->getValueMask();
        for (int w = 0; w < kLeafVoxels / 64; ++w) mask.template getWord<uint64_t>(w) = words[w];
        leafOut = leaf;
        if (withId) {
            auto* attr = new LeafT(openvdb::PartialCreate(), origin, kNoId);
            attr->buffer().allocate();
            float* a = attr->buffer().data();
            for (int n = 0; n < kLeafVoxels; ++n) {
                a[n] = (words[n >> 6] >> (n & 63)) & 1 ? s.outId[n] : kNoId;
            }
            auto& am = attr->getValueMask();
            for (int w = 0; w < kLeafVoxels / 64; ++w) am.template getWord<uint64_t>(w) = words[w];
            *attrOut = attr;
        }
    }

    double memoryLimit() const
    {
        return memoryLimitBytes(mS.maxMemoryBytes);
    }

    const Field& mField;
    const BakeSettings& mS;
    const Domain& mD;
    const float mDx;
    float mClampBand;
    float mReach;
    float mInvSlope = 1.0f; // 1 / max(1, field.lipschitz())
    openvdb::util::NullInterrupter* mInterrupt;
    std::atomic<bool> mCancel{false};
    std::atomic<bool> mOverflow{false};
    std::atomic<bool> mNaN{false};
    Coord mNaNLeaf;
    const openvdb::MaskTree* mCandidates =
        mS.candidates ? &mS.candidates->tree() : nullptr;
    const FloatTree* mSigns =
        mS.candidates && mS.candidateSigns ? &mS.candidateSigns->tree() : nullptr;
    std::atomic<size_t> mEvals{0};
    std::atomic<size_t> mActive{0};
};

} // namespace

Renormalize renormalizeFromString(const std::string& s)
{
    if (s == "auto") return Renormalize::Auto;
    if (s == "off" || s == "false" || s == "0") return Renormalize::Off;
    if (s == "on" || s == "true" || s == "1") return Renormalize::On;
    fail<ValueError>("bake: renormalize must be auto, on or off (got '", s, "')");
}

void BakeSettings::validate() const
{
    require(std::isfinite(voxelSize) && voxelSize > 0, "bake", "voxel size", "> 0", voxelSize);
    require(voxelSize >= 1e-6, "bake", "voxel size", ">= 1e-6 m", voxelSize);
    require(std::isfinite(halfWidth) && halfWidth >= 1 && halfWidth <= 64, "bake",
            "half width", "in [1, 64] voxels", halfWidth);
    require(std::isfinite(renormBandScale) && renormBandScale >= 1 && renormBandScale <= 8,
            "bake", "renormalisation band scale", "in [1, 8]", renormBandScale);
    require(trackerSteps >= 0 && trackerSteps <= 100, "bake", "tracker steps", "in [0, 100]",
            trackerSteps);
    require(std::isfinite(maxMemoryBytes) && maxMemoryBytes >= 0, "bake", "memory limit",
            ">= 0", maxMemoryBytes);
    if (gridName.empty()) fail<ValueError>("bake: grid name must not be empty");
    if (region) {
        const BBoxd& r = *region;
        for (int a = 0; a < 3; ++a) {
            require(std::isfinite(r.min()[a]) && std::isfinite(r.max()[a]) &&
                        r.min()[a] < r.max()[a],
                    "bake", "region", "finite with min < max on every axis",
                    std::to_string(r.min()[a]) + ".." + std::to_string(r.max()[a]));
        }
    }
}

double memoryLimitBytes(double maxBytes)
{
    return maxBytes > 0 ? maxBytes : 0.75 * physicalMemoryBytes();
}

double physicalMemoryBytes()
{
    const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
    return pages > 0 && size > 0 ? double(pages) * double(size) : 8e9;
}

std::string formatBytes(double bytes)
{
    const char* units[] = {"B", "KB", "MB", "GB", "TB", "PB", "EB"};
    int u = 0;
    while (bytes >= 1000 && u < 6) { bytes /= 1000; ++u; }
    char buf[32];
    std::snprintf(buf, sizeof buf, u ? "%.1f %s" : "%.0f %s", bytes, units[u]);
    return buf;
}

namespace {

// Active voxels ~ surface area of the domain box (an upper-ish bound for convex shapes)
// times the band thickness, never more than the voxels of the box itself.
double estimateActive(const CoordBBox& box, const BakeSettings& s, bool renormalize)
{
    if (box.empty()) return 0;
    const Coord ext = box.extents();
    const double a = ext[0], b = ext[1], c = ext[2];
    const double bandVoxels = 2.0 * s.halfWidth * (renormalize ? s.renormBandScale : 1.0);
    return std::min(2.0 * (a * b + b * c + c * a) * bandVoxels, a * b * c);
}

double bytesOf(double activeVoxels, const BakeSettings& s)
{
    return activeVoxels * kBytesPerActive * (s.withAttribute ? 2.0 : 1.0);
}

} // namespace

BakeEstimate estimateBake(const Field& field, const BakeSettings& s)
{
    s.validate();
    const Domain d = makeDomain(field, s);
    BakeEstimate e;
    e.indexBox = d.box;
    e.wholeBox = d.whole;
    if (d.box.empty()) { e.empty = true; return e; }
    e.activeVoxels = estimateActive(d.box, s, d.renormalize);
    e.bytes = bytesOf(e.activeVoxels, s);
    return e;
}

BBoxd regionOfBox(const CoordBBox& box, double voxelSize)
{
    // Half a voxel around the centres: index i is inside iff min <= i·dx < max.
    return BBoxd(Vec3d(box.min().x() - 0.5, box.min().y() - 0.5, box.min().z() - 0.5) * voxelSize,
                 Vec3d(box.max().x() + 0.5, box.max().y() + 0.5, box.max().z() + 0.5) * voxelSize);
}

BakeEstimate checkedEstimate(const Field& field, const BakeSettings& s)
{
    const BakeEstimate est = estimateBake(field, s);
    const double limit = memoryLimitBytes(s.maxMemoryBytes);
    if (est.bytes > limit) {
        // The extent too: a size read from an input file shows there, not as the user's voxel size.
        const openvdb::Coord dim = est.indexBox.dim();
        fail<ValueError>("bake: refusing to bake: about ", formatBytes(est.bytes), " needed (~",
                         est.activeVoxels, " active voxels at voxel size ", s.voxelSize,
                         " m over the input's ", double(dim.x()) * s.voxelSize, " x ",
                         double(dim.y()) * s.voxelSize, " x ", double(dim.z()) * s.voxelSize,
                         " m) exceeds the ", formatBytes(limit), " limit");
    }
    return est;
}

BakeResult bake(const Field& field, const BakeSettings& s,
                openvdb::util::NullInterrupter* interrupt)
{
    s.validate();
    if (planRequested()) {
        const Domain whole = makeDomain(field, s);
        reportPlanIfRequested("bake", whole.whole, s.voxelSize, s.chunk, [&](const CoordBBox& b) {
            return bytesOf(estimateActive(b, s, whole.renormalize), s);
        });
    }
    checkedEstimate(field, s);
    const Domain d = makeDomain(field, s);
    if (interrupt) interrupt->start("bake");
    Baker baker(field, s, d, interrupt);
    BakeResult r = baker.run();
    if (interrupt) interrupt->end();
    return r;
}

} // namespace rockvdb
