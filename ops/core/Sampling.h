// SPDX-License-Identifier: Apache-2.0
// rockvdb — point sampling in a periodic cube (the tiles of the block and rock stages).
//
// Every sampler is deterministic: its random numbers are (seed, stream, counter) hashes and
// the algorithms are sequential, so the same parameters give the same points on any machine
// and thread count.
#pragma once

#include <rockvdb/core/Field.h>

#include <array>
#include <cstdint>
#include <vector>

namespace rockvdb {

/// @brief Shortest periodic difference b - a in a cube of side @a size (each component in
/// [-size/2, size/2]).
Vec3d periodicDelta(const Vec3d& a, const Vec3d& b, double size);

/// @brief Poisson-sphere sampling of the periodic cube [0, size)³ (Bridson's algorithm
/// with wrap-around distances): no two points closer than @a radius, and no room left for
/// another after @a attempts candidates around every point.
/// @throw ValueError unless 0 < radius < size / 2.
std::vector<Vec3d> poissonPeriodic(double size, double radius, uint64_t seed, uint64_t stream,
                                   int attempts = 30);

/// @brief Poisson-sphere sampling of the box [lo, hi] (Bridson's algorithm, no wrap-around):
/// no two points closer than @a radius, and no room left for another after @a attempts
/// candidates around every point. Points pack against the box's faces: sample a margin
/// beyond where they are used.
/// @throw ValueError unless 0 < radius and the box holds at most ~64 M cells of radius/√3.
std::vector<Vec3d> poissonBox(const Vec3d& lo, const Vec3d& hi, double radius, uint64_t seed,
                              uint64_t stream, int attempts = 30);

/// @brief Dart throwing in the periodic cube: up to @a count uniform points at least
/// @a spacing apart (periodic), giving up after 200·count rejected darts.
std::vector<Vec3d> dartsPeriodic(double size, double spacing, int count, uint64_t seed,
                                 uint64_t stream);

/// @brief An edge of a periodic neighbour graph: points a < b, with b's image at
/// points[b] + shift·size the one nearest to points[a].
struct PeriodicEdge
{
    int a, b;
    std::array<int8_t, 3> shift;
};

/// @brief All pairs closer than @a radius (periodic distance), each once.
/// @throw ValueError unless 0 < radius < size / 2 (so the nearest image is unique).
std::vector<PeriodicEdge> neighbourGraph(const std::vector<Vec3d>& points, double size,
                                         double radius);

} // namespace rockvdb
