// SPDX-License-Identifier: Apache-2.0
// Fractal rocks: the icosahedron, deterministic midpoint displacement with up/down roughness,
// and subdivision damping (fractal-rocks-midpoint-displacement.txt §2–§5).
#include "FractalRock.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace rockvdb {
namespace fractal {

namespace {

// Random streams (core/Random.h).
enum Stream : uint64_t { kDisplacement = 0xf4ac1, kYaw = 0xf4ac2, kTilt = 0xf4ac3 };

const char* kMethodNames[] = {"interpolating", "approximating", "midpoint"};

// The unit icosahedron: vertices (0, ±1, ±φ) and their cyclic permutations, normalised;
// faces counter-clockwise seen from outside.
void icosahedron(std::vector<Vec3d>& v, std::vector<openvdb::Vec3I>& f)
{
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    for (auto& p : v) p.normalize();
    f = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
         {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
         {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
}

// The key of a point made from others: order-free in the parents (sorted by the caller).
inline uint64_t childKey(uint64_t a, uint64_t b, uint64_t c, uint64_t slot)
{
    return random::mix64(random::mix64(random::mix64(a * 0x9e3779b97f4a7c15ull + b) + c) + slot);
}

inline double smoothstep(double lo, double hi, double x)
{
    const double t = std::min(1.0, std::max(0.0, (x - lo) / (hi - lo)));
    return t * t * (3.0 - 2.0 * t);
}

// One level of subdivision: k steps per edge (4: damping, 2: midpoint).
struct Level
{
    const RockShape& shape;
    Vec3d extent, up;       // up: Rᵀ ẑ (world up in the canonical frame, before extents)
    double amplitude;       // roughness · ℓ0 (canonical metres)
    double ratio;           // ℓ_n / ℓ0 of this level's edges (nominal)

    // H of the edge whose undisplaced midpoint is m̂ (canonical): from the world direction of
    // the point, cos θ = (extent ∘ m̂) · Rᵀẑ / |extent ∘ m̂| (§4, Fig. 7). Per edge, not per
    // face as in the paper: the two faces of an edge must agree or the mesh cracks.
    double hurst(const Vec3d& m) const
    {
        const Vec3d w(m[0] * extent[0], m[1] * extent[1], m[2] * extent[2]);
        const double len = w.length();
        const double c = len > 0 ? w.dot(up) / len : 0.0;
        const double b = shape.hBlend;
        return shape.hDown + (shape.hUp - shape.hDown) * smoothstep(-b, b, c);
    }

    // The displaced midpoint (the control point of the damping variants): along the
    // direction from the centre, by roughness · ℓ0 · (ℓ_n/ℓ0)^H · ξ, ξ ∈ [−1, 1) from the
    // edge's key (§2, Smith's method).
    Vec3d midpoint(const Vec3d& p, const Vec3d& q, uint64_t key) const
    {
        const Vec3d m = (p + q) * 0.5;
        const double len = m.length();
        if (!(len > 0)) return m;
        const double xi = 2.0 * random::uniform(shape.seed, kDisplacement, key) - 1.0;
        const double d = amplitude * std::pow(ratio, hurst(m)) * xi;
        return m + m * (d / len);
    }
};

// Weights of the quadratic triangle patch at barycentric λ = (l0, l1, l2) over corners
// X0 X1 X2 and edge control points M01 M12 M20.
struct PatchWeights
{
    double corner[3], edge[3]; // edge[0]: M01, edge[1]: M12, edge[2]: M20
};

PatchWeights patchWeights(Method method, double l0, double l1, double l2)
{
    PatchWeights w;
    const double l[3] = {l0, l1, l2};
    if (method == Method::Interpolating) {
        // Quadratic Lagrange triangle: interpolates corners and displaced midpoints.
        for (int i = 0; i < 3; ++i) w.corner[i] = l[i] * (2.0 * l[i] - 1.0);
        for (int i = 0; i < 3; ++i) w.edge[i] = 4.0 * l[i] * l[(i + 1) % 3];
    } else {
        // Quadratic Bézier triangle: the displaced midpoints are control points.
        for (int i = 0; i < 3; ++i) w.corner[i] = l[i] * l[i];
        for (int i = 0; i < 3; ++i) w.edge[i] = 2.0 * l[i] * l[(i + 1) % 3];
    }
    return w;
}

struct EdgeRef
{
    unsigned lo, hi; // vertex indices, lo < hi
    unsigned slot;   // face * 3 + local edge
};

} // namespace

Method methodFromString(const std::string& name)
{
    for (int m = 0; m < 3; ++m) {
        if (name == kMethodNames[m]) return Method(m);
    }
    fail<ValueError>("fractal: unknown method '", name,
                     "' (expected interpolating, approximating or midpoint)");
}

const char* methodName(Method method) { return kMethodNames[int(method)]; }

double triangleCount(int levels, Method method)
{
    return 20.0 * std::pow(method == Method::Midpoint ? 4.0 : 16.0, levels);
}

double meshBytes(int levels, Method method)
{
    // Per triangle: its indices, base face and lattice corners (41 B), half a vertex
    // (position, key: 16 B), the edge sort (1.5 edges · 12 B), both levels alive at once
    // (× 1.25), and the world mesh with normals (~40 B).
    return triangleCount(levels, method) * ((41 + 16 + 18) * 1.25 + 40);
}

RockMesh buildRock(const RockShape& shape, const Vec3d& extent, const std::array<Vec3d, 3>& rotation,
                   Task& task)
{
    require(shape.levels >= 0 && shape.levels <= 12, "fractal", "levels", "in [0, 12]", shape.levels);
    const int k = shape.method == Method::Midpoint ? 2 : 4;
    RockMesh rock;
    std::vector<uint64_t> keys;
    icosahedron(rock.points, rock.triangles);
    keys.resize(rock.points.size());
    std::iota(keys.begin(), keys.end(), uint64_t(1));
    rock.baseFace.resize(20);
    rock.corners.resize(20);
    for (uint8_t f = 0; f < 20; ++f) {
        rock.baseFace[f] = f;
        rock.corners[f] = {0, 0, 1, 0, 0, 1};
    }
    rock.lattice = 1;

    const double l0 = 1.0 / std::sin(2.0 * M_PI / 5.0); // icosahedron edge on the unit sphere
    const int interior = (k - 1) * (k - 2) / 2;          // points inside a face per level
    const int perFace = k * k;                           // sub-triangles per face per level
    for (int level = 0; level < shape.levels; ++level) {
        task.check();
        Level L{shape, extent, rotation[2], shape.roughness * l0, std::pow(double(k), -level)};
        const size_t nv = rock.points.size(), nf = rock.triangles.size();

        // Unique edges, sorted by their endpoints (deterministic ids).
        std::vector<EdgeRef> refs(3 * nf);
        for (size_t f = 0; f < nf; ++f)
            for (int e = 0; e < 3; ++e) {
                const unsigned a = rock.triangles[f][e], b = rock.triangles[f][(e + 1) % 3];
                refs[3 * f + size_t(e)] = {std::min(a, b), std::max(a, b), unsigned(3 * f + size_t(e))};
            }
        std::sort(refs.begin(), refs.end(), [](const EdgeRef& x, const EdgeRef& y) {
            return x.lo != y.lo ? x.lo < y.lo : x.hi != y.hi ? x.hi < y.hi : x.slot < y.slot;
        });
        std::vector<unsigned> edgeOf(3 * nf);
        std::vector<std::pair<unsigned, unsigned>> edges;
        edges.reserve(3 * nf / 2);
        for (size_t i = 0; i < refs.size(); ++i) {
            if (i == 0 || refs[i].lo != refs[i - 1].lo || refs[i].hi != refs[i - 1].hi) {
                edges.emplace_back(refs[i].lo, refs[i].hi);
            }
            edgeOf[refs[i].slot] = unsigned(edges.size() - 1);
        }
        const size_t ne = edges.size();
        if (ne * 2 != 3 * nf) fail<ValueError>("fractal: internal error: the mesh is not closed");

        // New points: per edge k − 1 in order from its smaller-key endpoint, then per face
        // its interior points. Every new point is a pure function of its parents' keys.
        const size_t edgeBase = nv, faceBase = nv + ne * size_t(k - 1);
        const size_t total = faceBase + nf * size_t(interior);
        rock.points.resize(total);
        keys.resize(total);
        // Displaced midpoints (control points) per edge, for the face patches.
        std::vector<Vec3d> control(ne);
        tbb::parallel_for(size_t(0), ne, [&](size_t e) {
            unsigned p = edges[e].first, q = edges[e].second;
            if (keys[q] < keys[p]) std::swap(p, q);
            const uint64_t kp = keys[p], kq = keys[q];
            const Vec3d& P = rock.points[p];
            const Vec3d& Q = rock.points[q];
            const Vec3d M = L.midpoint(P, Q, childKey(kp, kq, 0, size_t(k) / 2));
            control[e] = M;
            for (int s = 1; s < k; ++s) {
                const size_t at = edgeBase + e * size_t(k - 1) + size_t(s - 1);
                keys[at] = childKey(kp, kq, 0, uint64_t(s));
                if (k == 2) {
                    rock.points[at] = M;
                    continue;
                }
                // The edge curve through P, M, Q (or with control point M) at t = s/4.
                const double t = double(s) / k;
                const PatchWeights w = patchWeights(shape.method, 1.0 - t, t, 0.0);
                rock.points[at] = P * w.corner[0] + Q * w.corner[1] + M * w.edge[0];
            }
        });

        // Faces: the k² sub-triangles of each face on its local lattice (a, b), a toward
        // corner 1, b toward corner 2; interior points on the face's quadratic patch.
        std::vector<openvdb::Vec3I> triangles(nf * size_t(perFace));
        std::vector<uint8_t> baseFace(triangles.size());
        std::vector<std::array<uint32_t, 6>> corners(triangles.size());
        tbb::parallel_for(size_t(0), nf, [&](size_t f) {
            const openvdb::Vec3I tri = rock.triangles[f];
            // Local index of lattice point (a, b) → mesh vertex.
            unsigned local[5][5];
            local[0][0] = tri[0];
            local[k][0] = tri[1];
            local[0][k] = tri[2];
            // Edge e runs from corner e to corner e+1: (0,0)→(k,0), (k,0)→(0,k), (0,k)→(0,0).
            auto at = [&](int e, int s) -> unsigned& { // s steps from corner e
                switch (e) {
                case 0: return local[s][0];
                case 1: return local[k - s][s];
                default: return local[0][k - s];
                }
            };
            Vec3d M[3];
            for (int e = 0; e < 3; ++e) {
                const unsigned id = edgeOf[3 * f + size_t(e)];
                const unsigned from = tri[e];
                const unsigned p = keys[edges[id].first] < keys[edges[id].second] ? edges[id].first
                                                                                 : edges[id].second;
                M[e] = control[id];
                for (int s = 1; s < k; ++s) {
                    const int slot = from == p ? s : k - s;
                    at(e, s) = unsigned(edgeBase + size_t(id) * size_t(k - 1) + size_t(slot - 1));
                }
            }
            if (interior > 0) {
                // Keys from the sorted corner keys and the nearest corner's key.
                uint64_t ck[3] = {keys[tri[0]], keys[tri[1]], keys[tri[2]]};
                std::sort(ck, ck + 3);
                const Vec3d& X0 = rock.points[tri[0]];
                const Vec3d& X1 = rock.points[tri[1]];
                const Vec3d& X2 = rock.points[tri[2]];
                int n = 0;
                for (int b = 1; b < k; ++b)
                    for (int a = 1; a + b < k; ++a) {
                        const size_t id = faceBase + f * size_t(interior) + size_t(n++);
                        const double l1 = double(a) / k, l2 = double(b) / k, l0 = 1.0 - l1 - l2;
                        const PatchWeights w = patchWeights(shape.method, l0, l1, l2);
                        rock.points[id] = X0 * w.corner[0] + X1 * w.corner[1] + X2 * w.corner[2] +
                                          M[0] * w.edge[0] + M[1] * w.edge[1] + M[2] * w.edge[2];
                        const uint64_t nearest = l0 >= l1 && l0 >= l2 ? keys[tri[0]]
                                                 : l1 >= l2          ? keys[tri[1]]
                                                                     : keys[tri[2]];
                        keys[id] = childKey(ck[0] ^ nearest, ck[1], ck[2], 0x1000 + uint64_t(a * 8 + b));
                        local[a][b] = unsigned(id);
                    }
            }
            // Lattice coordinates of the children (scale k × the parent's).
            const auto& pc = rock.corners[f];
            auto lattice = [&](int a, int b, uint32_t* out) {
                for (int c = 0; c < 2; ++c) {
                    const int64_t base = int64_t(pc[size_t(c)]) * k;
                    out[c] = uint32_t(base + (int64_t(pc[size_t(2 + c)]) - pc[size_t(c)]) * a +
                                      (int64_t(pc[size_t(4 + c)]) - pc[size_t(c)]) * b);
                }
            };
            size_t t = f * size_t(perFace);
            auto emit = [&](int a0, int b0, int a1, int b1, int a2, int b2) {
                triangles[t] = openvdb::Vec3I(local[a0][b0], local[a1][b1], local[a2][b2]);
                baseFace[t] = rock.baseFace[f];
                lattice(a0, b0, &corners[t][0]);
                lattice(a1, b1, &corners[t][2]);
                lattice(a2, b2, &corners[t][4]);
                ++t;
            };
            for (int b = 0; b < k; ++b)
                for (int a = 0; a + b < k; ++a) {
                    emit(a, b, a + 1, b, a, b + 1);                          // upright
                    if (a + b + 2 <= k) emit(a + 1, b, a + 1, b + 1, a, b + 1); // inverted
                }
        });
        rock.triangles.swap(triangles);
        rock.baseFace.swap(baseFace);
        rock.corners.swap(corners);
        rock.lattice *= uint32_t(k);
    }
    return rock;
}

// A rock's orientation: yaw uniform, then a tilt about a random horizontal axis with the
// tilted up axis uniform over the spherical cap of angle `tilt` (180°: uniform rotations).
std::array<Vec3d, 3> randomOrientation(uint64_t seed, double tiltDeg)
{
    const double yaw = 2 * M_PI * random::uniform(seed, kYaw, 0);
    const double capCos = std::cos(tiltDeg * M_PI / 180.0);
    const double c = 1.0 - random::uniform(seed, kTilt, 0) * (1.0 - capCos); // cos of the tilt
    const double tilt = std::acos(std::min(1.0, std::max(-1.0, c)));
    const double axis = 2 * M_PI * random::uniform(seed, kTilt, 1);
    // R = T(axis, tilt) · Z(yaw), T by Rodrigues about (cos axis, sin axis, 0).
    const double cy = std::cos(yaw), sy = std::sin(yaw);
    const Vec3d z0(cy, -sy, 0), z1(sy, cy, 0), z2(0, 0, 1); // rows of Z(yaw)
    const Vec3d k(std::cos(axis), std::sin(axis), 0);
    const double ct = std::cos(tilt), st = std::sin(tilt);
    std::array<Vec3d, 3> T;
    for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) {
            const double kk = k[r] * k[q] * (1 - ct);
            double cross = 0; // [k]× entries
            if (r == 0 && q == 1) cross = -k[2];
            if (r == 0 && q == 2) cross = k[1];
            if (r == 1 && q == 0) cross = k[2];
            if (r == 1 && q == 2) cross = -k[0];
            if (r == 2 && q == 0) cross = -k[1];
            if (r == 2 && q == 1) cross = k[0];
            T[size_t(r)][q] = (r == q ? ct : 0.0) + kk + st * cross;
        }
    std::array<Vec3d, 3> R;
    const Vec3d cols[3] = {Vec3d(z0[0], z1[0], z2[0]), Vec3d(z0[1], z1[1], z2[1]), Vec3d(z0[2], z1[2], z2[2])};
    for (int r = 0; r < 3; ++r)
        for (int q = 0; q < 3; ++q) R[size_t(r)][q] = T[size_t(r)].dot(cols[q]);
    return R;
}

std::array<double, 4> quaternionOf(const std::array<Vec3d, 3>& R)
{
    // Shepperd's method on the rows of R.
    const double tr = R[0][0] + R[1][1] + R[2][2];
    double x, y, z, w;
    if (tr > 0) {
        const double s = 2.0 * std::sqrt(1.0 + tr);
        w = 0.25 * s;
        x = (R[2][1] - R[1][2]) / s;
        y = (R[0][2] - R[2][0]) / s;
        z = (R[1][0] - R[0][1]) / s;
    } else if (R[0][0] > R[1][1] && R[0][0] > R[2][2]) {
        const double s = 2.0 * std::sqrt(1.0 + R[0][0] - R[1][1] - R[2][2]);
        w = (R[2][1] - R[1][2]) / s;
        x = 0.25 * s;
        y = (R[0][1] + R[1][0]) / s;
        z = (R[0][2] + R[2][0]) / s;
    } else if (R[1][1] > R[2][2]) {
        const double s = 2.0 * std::sqrt(1.0 + R[1][1] - R[0][0] - R[2][2]);
        w = (R[0][2] - R[2][0]) / s;
        x = (R[0][1] + R[1][0]) / s;
        y = 0.25 * s;
        z = (R[1][2] + R[2][1]) / s;
    } else {
        const double s = 2.0 * std::sqrt(1.0 + R[2][2] - R[0][0] - R[1][1]);
        w = (R[1][0] - R[0][1]) / s;
        x = (R[0][2] + R[2][0]) / s;
        y = (R[1][2] + R[2][1]) / s;
        z = 0.25 * s;
    }
    if (w < 0) { x = -x; y = -y; z = -z; w = -w; }
    return {x, y, z, w};
}

std::vector<Vec3d> toWorld(const RockMesh& rock, const Vec3d& extent,
                           const std::array<Vec3d, 3>& R, const Vec3d& centre)
{
    std::vector<Vec3d> out(rock.points.size());
    tbb::parallel_for(size_t(0), out.size(), [&](size_t i) {
        const Vec3d& p = rock.points[i];
        const Vec3d s(p[0] * extent[0], p[1] * extent[1], p[2] * extent[2]);
        out[i] = centre + Vec3d(R[0].dot(s), R[1].dot(s), R[2].dot(s));
    });
    return out;
}

std::vector<Vec3d> vertexNormals(const std::vector<Vec3d>& points,
                                 const std::vector<openvdb::Vec3I>& triangles)
{
    std::vector<Vec3d> n(points.size(), Vec3d(0));
    // Serial accumulation keeps the sums in one order (bitwise the same at any thread count).
    for (const auto& t : triangles) {
        const Vec3d c = (points[t[1]] - points[t[0]]).cross(points[t[2]] - points[t[0]]);
        n[t[0]] += c;
        n[t[1]] += c;
        n[t[2]] += c;
    }
    for (auto& v : n) {
        const double l = v.length();
        if (l > 0) v /= l;
    }
    return n;
}

openvdb::Vec2d UvLayout::uv(int face, double a, double b) const
{
    const int cell = face / 2, col = cell % 5, row = cell / 5;
    const double l0 = 1.0 - a - b;
    // The cell's half and its incentre (legs 1: inradius (2 − √2)/2).
    const double r = (2.0 - std::sqrt(2.0)) / 2.0;
    double x, y, ix, iy;
    if (face % 2 == 0) {
        x = a;  // corners (0,0), (1,0), (0,1)
        y = b;
        ix = iy = r;
    } else {
        x = l0 + b; // corners (1,1), (0,1), (1,0)
        y = l0 + a;
        ix = iy = 1.0 - r;
    }
    const double s = 1.0 - gutter / r;
    x = ix + (x - ix) * s;
    y = iy + (y - iy) * s;
    return openvdb::Vec2d((col + x) / 5.0, (row + y) / 2.0);
}

Mesh rockMesh(const RockMesh& rock, const std::vector<Vec3d>& world, bool withUvs,
              const UvLayout& layout)
{
    Mesh m;
    m.points.resize(world.size());
    for (size_t i = 0; i < world.size(); ++i) m.points[i] = openvdb::Vec3s(world[i]);
    m.triangles = rock.triangles;
    const std::vector<Vec3d> n = vertexNormals(world, rock.triangles);
    m.normals.resize(n.size());
    for (size_t i = 0; i < n.size(); ++i) m.normals[i] = openvdb::Vec3s(n[i]);
    if (withUvs) {
        // One uv per lattice point of each base face (seams between faces): index
        // face · P + j(n + 1) − j(j − 1)/2 + i.
        const uint32_t N = rock.lattice;
        const size_t P = size_t(N + 1) * (N + 2) / 2;
        m.uvs.resize(20 * P);
        for (int f = 0; f < 20; ++f)
            for (uint32_t j = 0; j <= N; ++j)
                for (uint32_t i = 0; i + j <= N; ++i) {
                    const size_t idx = size_t(f) * P + size_t(j) * (N + 1) - size_t(j) * (j - 1) / 2 + i;
                    m.uvs[idx] = openvdb::Vec2s(layout.uv(f, double(i) / N, double(j) / N));
                }
        m.triangleUvs.resize(rock.triangles.size());
        for (size_t t = 0; t < rock.triangles.size(); ++t) {
            const auto& c = rock.corners[t];
            for (int q = 0; q < 3; ++q) {
                const size_t i = c[size_t(2 * q)], j = c[size_t(2 * q + 1)];
                m.triangleUvs[t][q] = unsigned(size_t(rock.baseFace[t]) * P + j * (N + 1) - j * (j - 1) / 2 + i);
            }
        }
    }
    return m;
}

} // namespace fractal
} // namespace rockvdb
