// SPDX-License-Identifier: Apache-2.0
// Tile generation (§4.1 fracturing, §4.2 convex bases): the phases in order. The phases'
// pieces live in Fractures.cc, Clusters.cc and Fill.cc (TileBuild.h).
#include "BlockTile.h"

#include <rockvdb/blocks/Hull.h>
#include <rockvdb/blocks/TileBuild.h>
#include <rockvdb/core/Sampling.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <deque>
#include <map>
#include <numeric>
#include <tuple>

namespace rockvdb {
namespace blocks {

using namespace tilegen;

BlockTile generateTile(const BlockTileParams& in)
{
    Task task;
    return generateTile(in, task);
}

BlockTile generateTile(const BlockTileParams& in, Task& task)
{
    BlockTileParams p = in;
    p.resolveDefaults();
    p.validate();
    p.axis = p.axis.unit();
    for (size_t a = 0; a < p.authored.size(); ++a) {
        AuthoredBlock& ab = p.authored[a];
        if (ab.isExpression() && !ab.field) {
            ab.field = authoredExpressionField(ab.expression, "authored block " + std::to_string(a));
        }
    }
    // 1. Poisson-sphere points in the periodic tile.
    const auto t0 = Clock::now();
    std::vector<Vec3d> pts = poissonPeriodic(p.tileSize, p.pointRadius, p.seed, kPoints);
    const double sampling = since(t0);
    task.check();
    std::vector<Disc> discs = makeDiscs(p);
    BlockTile tile = buildTile(p, pts, std::move(discs), task);
    tile.stats.sampling = sampling;
    tile.stats.generation += sampling;
    return tile;
}

namespace tilegen {

BlockTile buildTile(const BlockTileParams& p, const std::vector<Vec3d>& pts, std::vector<Disc> discs,
                    Task& task)
{
    const double s = p.tileSize;
    BlockTile tile;
    tile.params = p;
    BlockTileStats& st = tile.stats;
    const auto tStart = Clock::now();
    st.points = pts.size();
    auto t0 = Clock::now();

    // Authored blocks claim the points inside them (their own image nearest each point).
    std::vector<int> owner(pts.size(), -1);
    std::vector<std::vector<Vec3d>> authoredPts(p.authored.size());
    for (size_t i = 0; i < pts.size(); ++i) {
        for (size_t a = 0; a < p.authored.size(); ++a) {
            Vec3d u;
            if (insideAuthored(p.authored[a], pts[i], s, u)) {
                owner[i] = int(a);
                authoredPts[a].push_back(u);
                break;
            }
        }
    }

    task.check();
    // 2. Neighbour graph (periodic).
    t0 = Clock::now();
    const std::vector<PeriodicEdge> edges = neighbourGraph(pts, s, p.neighbourRadius);
    st.edges = edges.size();
    st.graph = since(t0);

    task.check();
    // 3. Fractures cut the edges; authored blocks are cut out of the graph.
    t0 = Clock::now();
    tile.discs = std::move(discs);
    st.discs = tile.discs.size();
    const DiscGrid discGrid(tile.discs, s, p.neighbourRadius);
    std::vector<std::vector<Adjacent>> adj(pts.size());
    // With fill: the cut edges, both ways, with each disc image across them (relative to the
    // point; disc -1 for edges into authored blocks).
    struct Cut { int to; Vec3d step; int disc; Vec3d centre; };
    std::vector<std::vector<Cut>> cuts(p.fill ? pts.size() : 0);
    for (const auto& e : edges) {
        const Vec3d pa = pts[size_t(e.a)];
        const Vec3d pb = pts[size_t(e.b)] + Vec3d(e.shift[0], e.shift[1], e.shift[2]) * s;
        // With fill, every disc across a cut edge is kept: any of them may be the fracture
        // between the two clusters (one pass over the discs either way).
        const bool authored = owner[size_t(e.a)] >= 0 || owner[size_t(e.b)] >= 0;
        std::vector<std::pair<int, Vec3d>> across;
        if (p.fill && !authored) across = discGrid.cutters(pa, pb);
        const bool cut = authored || (p.fill ? !across.empty() : discGrid.cuts(pa, pb));
        if (cut) {
            ++st.cutEdges;
            if (p.fill) {
                if (across.empty()) across.emplace_back(-1, Vec3d(0));
                for (const auto& [d, c] : across) {
                    cuts[size_t(e.a)].push_back({e.b, pb - pa, d, c - pa});
                    cuts[size_t(e.b)].push_back({e.a, pa - pb, d, c - pb});
                }
            }
            continue;
        }
        adj[size_t(e.a)].push_back({e.b, pb - pa});
        adj[size_t(e.b)].push_back({e.a, pa - pb});
    }
    st.fracturing = since(t0);
    task.check();

    // 4. Clusters: connected components, unwrapped; wrapping clusters are cut opposite
    //    their first point; then split until no disc separates two of their points.
    t0 = Clock::now();
    std::vector<int> label(pts.size(), -1);
    int nextLabel = 0;
    std::vector<int> free;
    for (size_t i = 0; i < pts.size(); ++i) if (owner[i] < 0) free.push_back(int(i));
    std::deque<std::vector<int>> queue;
    for (auto& c : components(free, adj, label, nextLabel)) queue.push_back(std::move(c));
    std::vector<std::vector<Vec3d>> clusters;
    std::vector<std::vector<int>> members; // the clusters' point indices, as in clusters
    std::vector<std::vector<int>> small;   // with fill: clusters under min points, to merge
    std::vector<std::vector<Vec3d>> smallP;
    std::vector<Vec3d> pos(pts.size());
    std::vector<int> stamp(pts.size(), -1);
    int visit = 0;
    while (!queue.empty()) {
        std::vector<int> comp = std::move(queue.front());
        queue.pop_front();
        const int lab = label[size_t(comp[0])];
        int axis = -1;
        if (!unwrap(comp, pts, adj, label, lab, s, pos, stamp, visit++, axis)) {
            // Cut the loop around the torus with the plane half a tile from the first point.
            ++st.wrapCuts;
            const double cut = pts[size_t(comp[0])][axis] + 0.5 * s;
            std::vector<std::vector<Adjacent>>& A = adj;
            for (int m : comp) {
                auto& list = A[size_t(m)];
                list.erase(std::remove_if(list.begin(), list.end(), [&](const Adjacent& e) {
                    if (label[size_t(e.to)] != lab) return false;
                    const double a0 = pts[size_t(m)][axis], a1 = a0 + e.step[axis];
                    const double k0 = std::floor((a0 - cut) / s), k1 = std::floor((a1 - cut) / s);
                    return k0 != k1;
                }), list.end());
            }
            for (auto& c : components(comp, adj, label, nextLabel)) queue.push_back(std::move(c));
            continue;
        }
        std::vector<Vec3d> P;
        P.reserve(comp.size());
        for (int m : comp) P.push_back(pos[size_t(m)]);
        Vec3d centre;
        const int d = separatingDisc(P, tile.discs, s, centre);
        if (d >= 0) {
            // Visibility (§4.1): the fracture continues across this cluster — split it by
            // the disc's plane, then into connected parts.
            ++st.visibilitySplits;
            const Vec3d& n = tile.discs[size_t(d)].normal;
            std::vector<int> side[2];
            for (size_t m = 0; m < comp.size(); ++m) side[n.dot(P[m] - centre) >= 0].push_back(comp[m]);
            for (auto& part : side) {
                for (auto& c : components(part, adj, label, nextLabel)) queue.push_back(std::move(c));
            }
            continue;
        }
        if (int(comp.size()) < p.minPoints) {
            if (p.fill) {
                small.push_back(std::move(comp));
                smallP.push_back(std::move(P));
            } else {
                ++st.droppedClusters;
                st.droppedPoints += comp.size();
            }
            continue;
        }
        clusters.push_back(std::move(P));
        members.push_back(std::move(comp));
    }
    // With fill, a cluster under min points (a sliver between a fracture and its neighbour's
    // end, a corner cut off by two discs) joins a neighbour, so it neither leaves a void nor
    // becomes a block of its own that the smooth intersection would erode away (and Table 1's
    // counts stay the paper's): the neighbour it shares the most graph edges with whose
    // joint hull holds no point of a third cluster (a joint hull wrapped round another
    // cluster could not be separated from it by a plane, and its points would fall in the
    // fracture). A small cluster that no neighbour can take stays a block.
    std::vector<int> clusterOf(p.fill ? pts.size() : 0, -1);
    std::vector<int> indexIn(p.fill ? pts.size() : 0, -1); // position within its cluster
    std::vector<int> smallOf(p.fill ? pts.size() : 0, -1);
    auto enrol = [&](size_t c) {
        for (size_t i = 0; i < members[c].size(); ++i) {
            clusterOf[size_t(members[c][i])] = int(c);
            indexIn[size_t(members[c][i])] = int(i);
            smallOf[size_t(members[c][i])] = -1;
        }
    };
    for (size_t c = 0; p.fill && c < clusters.size(); ++c) enrol(c);
    for (size_t k = 0; k < small.size(); ++k) {
        for (int m : small[k]) smallOf[size_t(m)] = int(k);
    }
    for (size_t k = 0; k < small.size(); ++k) {
        // Edges (cut or not) from the small cluster's points to each large cluster.
        std::map<int, std::pair<int, Vec3d>> votes; // cluster → (edges, this frame → its frame)
        for (size_t i = 0; i < small[k].size(); ++i) {
            const int m = small[k][i];
            auto vote = [&](int to, const Vec3d& step) {
                const int c = clusterOf[size_t(to)];
                if (c < 0) return;
                auto& v = votes[c];
                if (v.first++ == 0) {
                    v.second = clusters[size_t(c)][size_t(indexIn[size_t(to)])] - step - smallP[k][i];
                }
            };
            for (const auto& e : cuts[size_t(m)]) vote(e.to, e.step);
            for (const auto& e : adj[size_t(m)]) vote(e.to, e.step);
        }
        std::vector<std::tuple<int, int, Vec3d>> candidates; // (−edges, cluster, shift)
        for (const auto& [c, v] : votes) candidates.emplace_back(-v.first, c, v.second);
        std::sort(candidates.begin(), candidates.end(), [](const auto& x, const auto& y) {
            return std::make_pair(std::get<0>(x), std::get<1>(x)) < std::make_pair(std::get<0>(y), std::get<1>(y));
        });
        int best = -1;
        Vec3d shift(0);
        for (const auto& [negEdges, c, sh] : candidates) {
            std::vector<Vec3d> joint = clusters[size_t(c)];
            for (const auto& q : smallP[k]) joint.push_back(q + sh);
            const Hull hull = convexHull(joint, 1e-6 * std::max(1.0, p.pointRadius));
            bool clean = true;
            if (hull.dimension == 3) {
                // Any other cluster's point, an authored block's included.
                // (a copy of c: a structured binding cannot be captured in C++17)
                auto third = [&, cc = c](int to) {
                    return clusterOf[size_t(to)] != cc && smallOf[size_t(to)] != int(k);
                };
                auto inside = [&](const Vec3d& q) {
                    for (const auto& h : hull.planes) {
                        if (h[0] * q[0] + h[1] * q[1] + h[2] * q[2] - h[3] > -1e-6) return false;
                    }
                    return true;
                };
                const std::vector<int>& mem = members[size_t(c)];
                for (size_t i = 0; i < joint.size() && clean; ++i) {
                    const int m = i < mem.size() ? mem[i] : small[k][i - mem.size()];
                    for (const auto& e : cuts[size_t(m)]) {
                        if (third(e.to) && inside(joint[i] + e.step)) { clean = false; break; }
                    }
                    for (const auto& e : adj[size_t(m)]) {
                        if (!clean) break;
                        if (third(e.to) && inside(joint[i] + e.step)) clean = false;
                    }
                }
            }
            if (clean) {
                best = c;
                shift = sh;
                break;
            }
        }
        if (best < 0) {
            clusters.push_back(std::move(smallP[k]));
            members.push_back(std::move(small[k]));
            enrol(clusters.size() - 1);
            continue;
        }
        ++st.mergedClusters;
        for (size_t i = 0; i < small[k].size(); ++i) {
            clusters[size_t(best)].push_back(smallP[k][i] + shift);
            members[size_t(best)].push_back(small[k][i]);
        }
        enrol(size_t(best));
    }
    // Counted at the end: a small cluster kept as a block can take a later one in and reach
    // min points (counting when it was kept overcounted by one in a clang build's tile).
    for (const auto& m : members) st.smallBlocks += int(m.size()) < p.minPoints;
    st.clustering = since(t0);
    task.check();

    // 5. Convex bases (CGAL hulls); ids: authored blocks first, then clusters in order of
    //    their smallest point (the queue order above is deterministic).
    t0 = Clock::now();
    for (size_t a = 0; a < p.authored.size(); ++a) {
        tile.blocks.push_back(makeAuthored(p.authored[a], authoredPts[a]));
    }
    std::vector<Block> made(clusters.size());
    ClusterSet cs; // the hulls as made, before any block grows
    cs.support.resize(clusters.size());
    cs.normals.resize(clusters.size());
    for (size_t c = 0; c < clusters.size(); ++c) {
        made[c] = makeBlock(clusters[c], p.pointRadius, p.smoothRadius);
        for (const auto& q : made[c].planes) cs.normals[c].emplace_back(q[0], q[1], q[2]);
        for (const auto& v : made[c].vertices) cs.support[c].emplace_back(v[0], v[1], v[2]);
        if (cs.support[c].empty()) cs.support[c] = clusters[c];
    }
    cs.points = std::move(clusters);
    const std::vector<std::vector<Vec3d>>& pointsOf = cs.points;
    // Blocks grow at most `cap` past their points.
    const double cap = p.neighbourRadius;
    std::vector<std::vector<Deferred>> deferredOf(made.size());
    // Each block grows on its own (TBB; its planes depend only on the hulls as made).
    if (p.fill) tbb::parallel_for(size_t(0), made.size(), [&](size_t c) {
        // Foreign neighbours: across cut edges, and uncut edges to points that visibility
        // splits or wrap cuts put in another cluster.
        std::vector<Foreign> foreign;
        const std::vector<int>& mem = members[c];
        auto add = [&](const Vec3d& q, int to, int disc, const Vec3d& centre) {
            // An expression block's points stop nothing: its neighbours grow by the cap into
            // it and it carves them (w away) in the tile field.
            const int own = owner[size_t(to)];
            if (own >= 0 && p.authored[size_t(own)].isExpression()) return;
            const int k = clusterOf[size_t(to)];
            const Vec3d off = k >= 0 ? q - pointsOf[size_t(k)][size_t(indexIn[size_t(to)])] : Vec3d(0);
            foreign.push_back({q, k, off, disc, centre});
        };
        for (size_t i = 0; i < mem.size(); ++i) {
            const Vec3d& at = pointsOf[c][i];
            for (const auto& e : cuts[size_t(mem[i])]) add(at + e.step, e.to, e.disc, at + e.centre);
            for (const auto& e : adj[size_t(mem[i])]) {
                if (clusterOf[size_t(e.to)] != int(c)) add(at + e.step, e.to, -1, Vec3d(0));
            }
        }
        growToFractures(made[c], int(c), cs, foreign, tile.discs, p.fractureWidth, cap,
                        deferredOf[c]);
    });
    // Grown blocks that still meet (neighbours across no separating disc, clusters that are
    // not graph neighbours reaching into one corner) get their pair's separating plane, both
    // sides mirrored; rounds repeat while new planes change what meets. The pairs are found
    // in parallel (per lower block) and applied in block order.
    struct Split { size_t k; std::array<double, 4> mine, theirs; };
    task.check();
    for (int round = 0; p.fill && round < 4; ++round) {
        task.check();
        std::vector<std::vector<std::pair<int, int>>> edges(made.size());
        tbb::parallel_for(size_t(0), made.size(), [&](size_t c) { edges[c] = edgesOf(made[c]); });
        std::vector<std::vector<Split>> splits(made.size());
        tbb::parallel_for(size_t(0), made.size(), [&](size_t c) {
            const Block& A = made[c];
            for (size_t k = c; k < made.size(); ++k) {
                const Block& B = made[k];
                for (int i = -1; i <= 1; ++i)
                    for (int j = -1; j <= 1; ++j)
                        for (int l = -1; l <= 1; ++l) {
                            // A block and its own images too (k == c, a shift).
                            if (k == c && std::make_tuple(i, j, l) <= std::make_tuple(0, 0, 0)) continue;
                            const Vec3d off = Vec3d(i, j, l) * s; // k's frame → c's
                            bool near = true;
                            for (int a = 0; a < 3 && near; ++a) {
                                near = B.boundsMin[size_t(a)] + off[a] < A.boundsMax[size_t(a)] &&
                                       A.boundsMin[size_t(a)] < B.boundsMax[size_t(a)] + off[a];
                            }
                            if (!near || !meets(A, edges[c], B, edges[k], off, 1e-6)) continue;
                            // The discs across their edges, if they are graph neighbours.
                            const std::vector<std::pair<int, Vec3d>>* cut = nullptr;
                            for (const auto& d : deferredOf[c]) {
                                if (d.cluster == int(k) && (d.offset - off).length() < 1e-3) cut = &d.cut;
                            }
                            static const std::vector<std::pair<int, Vec3d>> none;
                            Vec3d n;
                            double m;
                            if (!pairPlane(cs, int(c), int(k), off, cut ? *cut : none, tile.discs,
                                           false, n, m)) continue;
                            // c's plane n·x <= m − w/2; in k's frame (x_c = x_k + off) k keeps
                            // −n·x_k <= n·off − m − w/2.
                            const double hw = 0.5 * p.fractureWidth;
                            splits[c].push_back({k, {n[0], n[1], n[2], m - hw},
                                                 {-n[0], -n[1], -n[2], n.dot(off) - m - hw}});
                        }
            }
        });
        std::vector<std::vector<std::array<double, 4>>> extra(made.size());
        size_t added = 0;
        for (size_t c = 0; c < made.size(); ++c) {
            for (const auto& sp : splits[c]) {
                extra[c].push_back(sp.mine);
                extra[sp.k].push_back(sp.theirs);
                ++added;
            }
        }
        if (added == 0) break;
        tbb::parallel_for(size_t(0), made.size(), [&](size_t c) {
            if (extra[c].empty()) return;
            std::vector<std::array<double, 4>> all = extra[c];
            for (const auto& q : made[c].planes) all.push_back({q[0], q[1], q[2], q[3]});
            setPolytope(made[c], all, pointsOf[c]);
        });
    }
    std::vector<size_t> order(made.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        const auto& x = made[a].anchors[0];
        const auto& y = made[b].anchors[0];
        return std::tie(x[2], x[1], x[0]) < std::tie(y[2], y[1], y[0]);
    });
    for (size_t k : order) tile.blocks.push_back(std::move(made[k]));
    for (auto& b : tile.blocks) toHome(b, s);
    st.hulls = since(t0);
    st.generation = since(tStart);
    st.blocks = tile.blocks.size();
    size_t sum = 0;
    for (const auto& b : tile.blocks) sum += size_t(b.points);
    st.meanPoints = tile.blocks.empty() ? 0.0 : double(sum) / double(tile.blocks.size());
    return tile;
}

} // namespace tilegen

} // namespace blocks
} // namespace rockvdb
