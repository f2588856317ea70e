// Narrow-band level sets of closed triangle meshes (see MeshBake.h).
#include "MeshBake.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridUtil.h>

#include <openvdb/tools/SignedFloodFill.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace rockvdb {
namespace fractal {

namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;

// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection §5.1.5) and the
// feature it lies on: 0 the face, 1..3 the vertices a, b, c, 4..6 the edges ab, bc, ca.
inline Vec3d closestOnTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c,
                               int& feature)
{
    const Vec3d ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0 && d2 <= 0) { feature = 1; return a; }
    const Vec3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0 && d4 <= d3) { feature = 2; return b; }
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        feature = 4;
        return a + ab * (d1 / (d1 - d3));
    }
    const Vec3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0 && d5 <= d6) { feature = 3; return c; }
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        feature = 6;
        return a + ac * (d2 / (d2 - d6));
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        feature = 5;
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    const double denom = 1.0 / (va + vb + vc);
    feature = 0;
    return a + ab * (vb * denom) + ac * (vc * denom);
}

// A part in index space with its pseudo-normals: per face, per face edge (the two faces'
// normals summed) and per vertex (angle-weighted).
struct Prepared
{
    std::vector<Vec3d> p;                  // index space
    const std::vector<openvdb::Vec3I>* t = nullptr;
    std::vector<Vec3d> face, vertex;
    std::vector<std::array<Vec3d, 3>> edge; // per triangle: ab, bc, ca
    std::vector<std::array<double, 6>> box; // per triangle: index-space bounds
    openvdb::Coord lo, hi;                  // leaf-aligned voxel box of the part's band
};

Prepared prepare(const MeshPart& part, double dx, double w)
{
    Prepared r;
    const auto& pts = *part.points;
    const auto& tris = *part.triangles;
    r.t = &tris;
    r.p.resize(pts.size());
    Vec3d lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (size_t i = 0; i < pts.size(); ++i) {
        r.p[i] = pts[i] / dx;
        lo = minComponent(lo, r.p[i]);
        hi = maxComponent(hi, r.p[i]);
    }
    r.face.resize(tris.size());
    r.vertex.assign(pts.size(), Vec3d(0));
    r.edge.resize(tris.size());
    r.box.resize(tris.size());
    // Edges by their endpoints: the two faces of each (a closed mesh has exactly two).
    std::vector<std::pair<uint64_t, uint32_t>> edges(3 * tris.size());
    for (size_t t = 0; t < tris.size(); ++t) {
        const Vec3d& a = r.p[tris[t][0]];
        const Vec3d& b = r.p[tris[t][1]];
        const Vec3d& c = r.p[tris[t][2]];
        Vec3d n = (b - a).cross(c - a);
        const double len = n.length();
        r.face[t] = len > 0 ? n / len : Vec3d(0);
        const Vec3d* v[3] = {&a, &b, &c};
        for (int k = 0; k < 3; ++k) {
            const Vec3d e1 = *v[(k + 1) % 3] - *v[k], e2 = *v[(k + 2) % 3] - *v[k];
            const double l1 = e1.length(), l2 = e2.length();
            const double angle = l1 > 0 && l2 > 0 ? std::acos(std::min(1.0, std::max(-1.0, e1.dot(e2) / (l1 * l2)))) : 0.0;
            r.vertex[tris[t][k]] += r.face[t] * angle;
            const uint64_t i = tris[t][k], j = tris[t][(k + 1) % 3];
            edges[3 * t + size_t(k)] = {std::min(i, j) << 32 | std::max(i, j), uint32_t(3 * t + size_t(k))};
        }
        r.box[t] = {std::min({a[0], b[0], c[0]}), std::min({a[1], b[1], c[1]}), std::min({a[2], b[2], c[2]}),
                    std::max({a[0], b[0], c[0]}), std::max({a[1], b[1], c[1]}), std::max({a[2], b[2], c[2]})};
    }
    std::sort(edges.begin(), edges.end());
    for (size_t i = 0; i < edges.size(); ++i) {
        const size_t t = edges[i].second / 3;
        const int k = int(edges[i].second % 3);
        Vec3d sum = r.face[t];
        // The other face of this edge: its neighbour in the sorted list with the same key.
        if (i + 1 < edges.size() && edges[i + 1].first == edges[i].first) sum += r.face[edges[i + 1].second / 3];
        else if (i > 0 && edges[i - 1].first == edges[i].first) sum += r.face[edges[i - 1].second / 3];
        r.edge[t][size_t(k)] = sum;
    }
    const int pad = int(std::ceil(w)) + 1;
    r.lo = openvdb::Coord(floorDiv(int(std::floor(lo[0])) - pad, 8) * 8, floorDiv(int(std::floor(lo[1])) - pad, 8) * 8,
                          floorDiv(int(std::floor(lo[2])) - pad, 8) * 8);
    r.hi = openvdb::Coord(floorDiv(int(std::ceil(hi[0])) + pad, 8) * 8 + 7, floorDiv(int(std::ceil(hi[1])) + pad, 8) * 8 + 7,
                          floorDiv(int(std::ceil(hi[2])) + pad, 8) * 8 + 7);
    return r;
}

// One slab of a part: 8 voxels along x (one leaf row), its leaves.
struct SlabOut
{
    std::vector<LeafT*> surface, ids;
};

void bakeSlab(const Prepared& P, int x0, double w, double dx, float partId, bool withIds,
              SlabOut& out)
{
    const auto& tris = *P.t;
    const int ny = P.hi[1] - P.lo[1] + 1, nz = P.hi[2] - P.lo[2] + 1;
    const size_t n = size_t(8) * size_t(ny) * size_t(nz);
    const double w2 = w * w;
    std::vector<float> d2(n, float(w2));
    std::vector<int32_t> best(n, -1);
    auto at = [&](int i, int j, int k) {
        return (size_t(i - x0) * size_t(ny) + size_t(j - P.lo[1])) * size_t(nz) + size_t(k - P.lo[2]);
    };
    for (size_t t = 0; t < tris.size(); ++t) {
        const auto& b = P.box[t];
        const int i0 = std::max(x0, int(std::ceil(b[0] - w))), i1 = std::min(x0 + 7, int(std::floor(b[3] + w)));
        if (i0 > i1) continue;
        const int j0 = std::max(P.lo[1], int(std::ceil(b[1] - w))), j1 = std::min(P.hi[1], int(std::floor(b[4] + w)));
        const int k0 = std::max(P.lo[2], int(std::ceil(b[2] - w))), k1 = std::min(P.hi[2], int(std::floor(b[5] + w)));
        const Vec3d& A = P.p[tris[t][0]];
        const Vec3d& B = P.p[tris[t][1]];
        const Vec3d& C = P.p[tris[t][2]];
        const Vec3d& nrm = P.face[t];
        for (int i = i0; i <= i1; ++i) {
            const double ex = std::max({b[0] - i, 0.0, i - b[3]});
            for (int j = j0; j <= j1; ++j) {
                // Only voxels within w of the triangle's box: a capped column, not the whole
                // box (for sub-voxel triangles the ball is half the cube).
                const double ey = std::max({b[1] - j, 0.0, j - b[4]});
                const double r2 = w2 - ex * ex - ey * ey;
                if (r2 < 0) continue;
                const double r = std::sqrt(r2);
                const int ka = std::max(k0, int(std::ceil(b[2] - r))), kb = std::min(k1, int(std::floor(b[5] + r)));
                for (int k = ka; k <= kb; ++k) {
                    const size_t v = at(i, j, k);
                    const Vec3d p(i, j, k);
                    const double pd = nrm.dot(p - A);
                    if (pd * pd >= double(d2[v])) continue; // the plane is already farther
                    int feature;
                    const double dd = (p - closestOnTriangle(p, A, B, C, feature)).lengthSqr();
                    if (dd < double(d2[v])) {
                        d2[v] = float(dd);
                        best[v] = int32_t(t);
                    }
                }
            }
        }
    }
    // Leaves: signed distances where a triangle is within the band.
    const float bg = float(w * dx);
    for (int j = P.lo[1]; j <= P.hi[1]; j += 8)
        for (int k = P.lo[2]; k <= P.hi[2]; k += 8) {
            LeafT* leaf = nullptr;
            LeafT* idLeaf = nullptr;
            for (int a = 0; a < 8; ++a)
                for (int bb = 0; bb < 8; ++bb)
                    for (int c = 0; c < 8; ++c) {
                        const size_t v = at(x0 + a, j + bb, k + c);
                        const int32_t t = best[v];
                        if (t < 0) continue;
                        if (!leaf) {
                            leaf = new LeafT(openvdb::Coord(x0, j, k), bg, false);
                            if (withIds) idLeaf = new openvdb::FloatTree::LeafNodeType(openvdb::Coord(x0, j, k), -1.0f, false);
                        }
                        const Vec3d p(x0 + a, j + bb, k + c);
                        const auto& tri = tris[size_t(t)];
                        int feature;
                        const Vec3d q = closestOnTriangle(p, P.p[tri[0]], P.p[tri[1]], P.p[tri[2]], feature);
                        const Vec3d& pseudo = feature == 0 ? P.face[size_t(t)]
                                              : feature <= 3 ? P.vertex[tri[feature - 1]]
                                                             : P.edge[size_t(t)][size_t(feature - 4)];
                        const double dist = std::sqrt(double(d2[v]));
                        const float value = float((pseudo.dot(p - q) < 0 ? -dist : dist) * dx);
                        const openvdb::Index offset = LeafT::coordToOffset(openvdb::Coord(a, bb, c));
                        leaf->setValueOn(offset, value);
                        if (idLeaf) idLeaf->setValueOn(offset, partId);
                    }
            if (leaf) {
                out.surface.push_back(leaf);
                if (idLeaf) out.ids.push_back(idLeaf);
            }
        }
}

} // namespace

openvdb::FloatGrid::Ptr bakeMeshes(const std::vector<MeshPart>& parts, double voxelSize,
                                   double halfWidth, bool disjoint, Task& task,
                                   openvdb::FloatGrid::Ptr* ids)
{
    const double dx = voxelSize, w = halfWidth;
    std::vector<Prepared> prepared(parts.size());
    parallelFor(task, parts.size(), 1, [&](size_t i) { prepared[i] = prepare(parts[i], dx, w); });
    // Work units: (part, slab), in part then slab order; each bakes alone.
    std::vector<std::pair<uint32_t, int>> units;
    for (size_t i = 0; i < prepared.size(); ++i) {
        for (int x = prepared[i].lo[0]; x <= prepared[i].hi[0]; x += 8) units.emplace_back(uint32_t(i), x);
    }
    std::vector<SlabOut> outs(units.size());
    try {
        parallelFor(task, units.size(), 1, [&](size_t u) {
            bakeSlab(prepared[units[u].first], units[u].second, w, dx, float(units[u].first),
                     ids != nullptr, outs[u]);
        });
    } catch (...) {
        for (auto& o : outs) {
            for (LeafT* l : o.surface) delete l;
            for (LeafT* l : o.ids) delete l;
        }
        throw;
    }
    auto xf = openvdb::math::Transform::createLinearTransform(dx);
    const float bg = float(w * dx);
    if (disjoint) {
        // Parts whose insides do not meet: no part's band reaches another's deep inside (a
        // voxel within the band of B and inside A is within the band of A too), so the union
        // is the min over the active voxels, and one flood fill signs the rest.
        auto surface = emptyLevelSet("surface", xf, bg);
        openvdb::FloatGrid::Ptr idGrid = ids ? emptyAttribute("rock_id", xf, -1.0f) : nullptr;
        auto& tree = surface->tree();
        for (auto& o : outs) {
            for (size_t l = 0; l < o.surface.size(); ++l) {
                LeafT* leaf = o.surface[l];
                LeafT* idLeaf = ids ? o.ids[l] : nullptr;
                LeafT* have = tree.probeLeaf(leaf->origin());
                if (!have) {
                    tree.addLeaf(leaf);
                    if (idLeaf) idGrid->tree().addLeaf(idLeaf);
                    continue;
                }
                LeafT* haveId = idLeaf ? idGrid->tree().probeLeaf(leaf->origin()) : nullptr;
                for (auto it = leaf->cbeginValueOn(); it; ++it) {
                    const openvdb::Index v = it.pos();
                    if (!have->isValueOn(v) || *it < have->getValue(v)) {
                        have->setValueOn(v, *it);
                        if (haveId) haveId->setValueOn(v, idLeaf->getValue(v));
                    }
                }
                delete leaf;
                delete idLeaf;
            }
            o.surface.clear();
            o.ids.clear();
        }
        task.check();
        openvdb::tools::signedFloodFill(tree);
        if (ids) *ids = idGrid;
        return surface;
    }
    // Each part alone: its leaves in one tree, signedFloodFill for its inactive voxels' signs
    // and its inside tiles (a part's leaf may hold voxels deep inside it, beyond its band).
    std::vector<std::unique_ptr<openvdb::FloatTree>> trees(parts.size()), idTrees(parts.size());
    {
        std::vector<size_t> firstUnit(parts.size() + 1, units.size());
        for (size_t u = units.size(); u-- > 0;) firstUnit[units[u].first] = u;
        for (size_t i = parts.size(); i-- > 0;) firstUnit[i] = std::min(firstUnit[i], firstUnit[i + 1]);
        parallelFor(task, parts.size(), 1, [&](size_t i) {
            trees[i] = std::make_unique<openvdb::FloatTree>(bg);
            if (ids) idTrees[i] = std::make_unique<openvdb::FloatTree>(-1.0f);
            for (size_t u = firstUnit[i]; u < firstUnit[i + 1]; ++u) {
                for (LeafT* l : outs[u].surface) trees[i]->addLeaf(l);
                for (LeafT* l : outs[u].ids) idTrees[i]->addLeaf(l);
                outs[u].surface.clear();
                outs[u].ids.clear();
            }
            openvdb::tools::signedFloodFill(*trees[i]);
        });
    }
    auto surface = emptyLevelSet("surface", xf, bg);
    openvdb::FloatGrid::Ptr idGrid = ids ? emptyAttribute("rock_id", xf, -1.0f) : nullptr;
    // The union, part by part in part order: min of the full values (tiles and inactive
    // voxels included), active where it lies inside the band.
    auto& tree = surface->tree();
    for (size_t i = 0; i < parts.size(); ++i) {
        task.check();
        openvdb::FloatTree& part = *trees[i];
        // Its inside tiles are inside the union: they replace whatever lies there.
        std::vector<std::pair<openvdb::Coord, openvdb::Index>> tiles;
        for (auto it = part.cbeginValueOff(); it; ++it) {
            if (!it.isVoxelValue() && *it < 0) tiles.emplace_back(it.getCoord(), it.getLevel());
        }
        std::vector<LeafT*> leaves, idLeaves;
        part.stealNodes(leaves);
        if (ids) idTrees[i]->stealNodes(idLeaves);
        for (const auto& [xyz, level] : tiles) {
            tree.addTile(level, xyz, -bg, false);
            if (ids) idGrid->tree().addTile(level, xyz, -1.0f, false);
        }
        for (size_t l = 0; l < leaves.size(); ++l) {
            LeafT* leaf = leaves[l];
            LeafT* idLeaf = ids ? idLeaves[l] : nullptr;
            LeafT* have = tree.probeLeaf(leaf->origin());
            if (!have) {
                if (tree.getValue(leaf->origin()) < 0) {
                    // Inside an earlier part's tile: the union is inside here.
                    delete leaf;
                    delete idLeaf;
                    continue;
                }
                tree.addLeaf(leaf);
                if (idLeaf) idGrid->tree().addLeaf(idLeaf);
                continue;
            }
            LeafT* haveId = ids ? idGrid->tree().touchLeaf(leaf->origin()) : nullptr;
            for (openvdb::Index v = 0; v < LeafT::SIZE; ++v) {
                const float mine = leaf->getValue(v), theirs = have->getValue(v);
                if (mine < theirs) {
                    have->setValueOnly(v, mine);
                    if (haveId) haveId->setValueOnly(v, idLeaf->getValue(v));
                }
                const bool on = std::abs(have->getValue(v)) < bg;
                have->setActiveState(v, on);
                if (haveId) haveId->setActiveState(v, on);
            }
            delete leaf;
            delete idLeaf;
        }
        trees[i].reset();
        if (ids) idTrees[i].reset();
    }
    if (ids) *ids = idGrid;
    return surface;
}

} // namespace fractal
} // namespace rockvdb
