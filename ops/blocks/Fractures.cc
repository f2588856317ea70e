// SPDX-License-Identifier: Apache-2.0
// Block tiles: the fracture discs per block type (implicit-blocks-rocky-scenery.txt §4.1).
#include <rockvdb/blocks/TileBuild.h>

#include <rockvdb/core/Random.h>
#include <rockvdb/core/Sampling.h>

#include <algorithm>
#include <cmath>

namespace rockvdb {
namespace blocks {

namespace tilegen {

// ---- fracture discs per block type (§4.1) ----------------------------------------------

std::vector<Disc> makeDiscs(const BlockTileParams& p, int64_t frameSeed)
{
    const double s = p.tileSize;
    const Vec3d u = p.axis.unit();
    Vec3d e1, e2;
    frame(u, e1, e2);
    // A random rotation of the set directions about the axis, fixed per seed.
    const double spin = 2 * M_PI * random::uniform(frameSeed < 0 ? p.seed : uint64_t(frameSeed), kFrame, 0);
    const Vec3d f1 = e1 * std::cos(spin) + e2 * std::sin(spin);
    const Vec3d f2 = u.cross(f1);

    std::vector<Vec3d> centres = dartsPeriodic(s, p.discSpacing, p.discCount, p.seed, kDiscCentres);
    std::vector<Disc> discs;
    auto rnd = [&](size_t i, uint64_t k) { return random::uniform(p.seed, kDiscShape, i * 8 + k); };
    auto radius = [&](size_t i) {
        return p.discRadiusMin + (p.discRadiusMax - p.discRadiusMin) * rnd(i, 0);
    };
    auto irregular = [&](size_t i) { return rnd(i, 1) < p.irregularFraction; };
    auto randomNormal = [&](size_t i) { return unitVector(rnd(i, 2), rnd(i, 3)); };
    // Disc i of a set of evenly spaced fractures (sets take discs in turn): its offset along
    // the set normal is stratified, k-th of m, jittered by a quarter spacing; its position
    // across the set is uniform.
    const size_t perSet = std::max<size_t>(1, (centres.size() + 2) / 3);
    auto inSet = [&](size_t i, const Vec3d& n) {
        Vec3d a, b;
        frame(n, a, b);
        const double k = double(i / 3) + 0.5 + 0.5 * (rnd(i, 7) - 0.5);
        Vec3d c = n * (k * s / double(perSet)) + a * (s * rnd(i, 2)) + b * (s * rnd(i, 3));
        for (int ax = 0; ax < 3; ++ax) c[ax] -= s * std::floor(c[ax] / s);
        return c;
    };

    // Three sets of discs taken in turn, evenly spaced along their (jittered) normals, plus
    // the irregular share with random normals (equidimensional, prismatic, rhombohedral).
    auto threeSets = [&](const Vec3d (&dirs)[3]) {
        for (size_t i = 0; i < centres.size(); ++i) {
            if (irregular(i)) {
                discs.push_back({centres[i], randomNormal(i), radius(i)});
                continue;
            }
            const int set = int(i % 3);
            discs.push_back({inSet(i, dirs[set]),
                             jitter(dirs[set], p.jitterDeg, rnd(i, 5), rnd(i, 6)), radius(i)});
        }
    };

    switch (p.type) {
    case BlockType::Equidimensional:
    case BlockType::Prismatic: {
        // Three approximately orthogonal, evenly spaced sets (§3: "a family of parallel,
        // evenly spaced fractures"; discs assigned to the sets in turn, stratified along the
        // set normal) plus occasional irregular fractures; prismatic differs only by its
        // larger jitter and irregular share (its defaults): "slightly more irregular".
        // Exactly the frame's axes (the tile's axes for the default axis z): a set normal
        // that is not a lattice direction meets its own periodic images at other offsets,
        // and the gaps between them become sliver blocks.
        const Vec3d dirs[3] = {e1, e2, u};
        threeSets(dirs);
        break;
    }
    case BlockType::Polyhedral:
        // No arrangement into sets: uniformly random normals, dense small discs.
        for (size_t i = 0; i < centres.size(); ++i) {
            discs.push_back({centres[i], randomNormal(i), radius(i)});
        }
        break;
    case BlockType::Rhombohedral: {
        // Three mutually oblique sets: unit normals at polar angle β around the axis, 120°
        // apart in azimuth, with pairwise angle θ: cos θ = 1 - 1.5 sin²β (θ = 90° gives the
        // equidimensional cube tilted onto its diagonal; the default θ = 60° a rhombohedron).
        const double cosT = std::cos(p.obliqueDeg * M_PI / 180.0);
        const double sinB = std::sqrt((1.0 - cosT) / 1.5), cosB = std::sqrt(1 - sinB * sinB);
        Vec3d dirs[3];
        for (int k = 0; k < 3; ++k) {
            const double az = 2 * M_PI * k / 3.0;
            dirs[k] = (u * cosB + (f1 * std::cos(az) + f2 * std::sin(az)) * sinB).unit();
        }
        threeSets(dirs);
        break;
    }
    case BlockType::Tabular: {
        // One dominant set of bedding planes orthogonal to the axis with radius s (they cross
        // the whole periodic tile), at stratified heights so beds have comparable thickness;
        // the other discs are small (s/10) and parallel to the two orthogonal axes.
        const int beds = std::max(1, int(std::lround(p.discCount / 3.0)));
        const Vec3d origin(0);
        for (int k = 0; k < beds; ++k) {
            const double h = (k + 0.25 + 0.5 * random::uniform(p.seed, kBedding, uint64_t(k))) *
                             s / beds;
            const Vec3d c = origin + u * h + f1 * (s * random::uniform(p.seed, kBedding, 1000 + k)) +
                            f2 * (s * random::uniform(p.seed, kBedding, 2000 + k));
            // No tilt: a tilted disc of radius s would meet its own periodic images as
            // stacked sheets (slivers) instead of one bedding plane.
            discs.push_back({c, u, s});
        }
        const size_t small = size_t(std::max(0, p.discCount - beds));
        for (size_t i = 0; i < centres.size() && i < small; ++i) {
            const Vec3d n = jitter(rnd(i, 4) < 0.5 ? f1 : f2, p.jitterDeg, rnd(i, 5), rnd(i, 6));
            discs.push_back({centres[i], n, radius(i)});
        }
        break;
    }
    case BlockType::Columnar: {
        // Columnar jointing (basalt colonnades): three sets of long, continuous fractures
        // parallel to the column axis, their normals 60° apart in the plane orthogonal to it
        // (the hexagonal habit of cooling joints), so columns are polygonal prisms much
        // longer than wide; a few short cross-joints orthogonal to the axis break them into
        // long segments (the irregular share of the discs).
        for (size_t i = 0; i < centres.size(); ++i) {
            if (irregular(i)) {
                discs.push_back({centres[i], jitter(u, p.jitterDeg, rnd(i, 5), rnd(i, 6)),
                                 0.5 * radius(i)});
            } else {
                // Jitter the azimuth only: the normal stays orthogonal to the axis, so the
                // long discs stay coplanar with their images along the column.
                const int set = int(i % 3);
                const double az = M_PI * set / 3.0 + (2 * rnd(i, 5) - 1) * p.jitterDeg * M_PI / 180.0;
                const Vec3d n = f1 * std::cos(az) + f2 * std::sin(az);
                discs.push_back({inSet(i, n), n, radius(i)});
            }
        }
        break;
    }
    }
    for (const auto& d : p.extraDiscs) discs.push_back({d.center, d.normal.unit(), d.radius});
    return discs;
}

} // namespace tilegen
} // namespace blocks
} // namespace rockvdb
