// SPDX-License-Identifier: Apache-2.0
// Initial material stacks (see StackBuild.h).
#include "StackBuild.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Noise.h>

#include <algorithm>
#include <cmath>

namespace rockvdb {
namespace arches {

namespace {

// Whole quanta of a height above z0 (rounded to nearest).
uint32_t quanta(double metres, double q)
{
    const double n = std::round(metres / q);
    if (!(n >= 0) || n > 4.0e9) fail<ValueError>("stacks: height ", metres, " m is out of range for quantum ", q, " m");
    return uint32_t(n);
}

} // namespace

Stacks stacksFromHeightfield(const Heightfield& hf, double quantum, double z0, double sandDepth,
                             const std::vector<float>* sandMap, Task& task)
{
    hf.validate("arches");
    if (!(sandDepth >= 0) || !std::isfinite(sandDepth)) fail<ValueError>("arches: sand depth must be >= 0 (got ", sandDepth, ")");
    if (sandMap && sandMap->size() != size_t(hf.nx) * size_t(hf.ny)) {
        fail<ValueError>("arches: the sand map has ", sandMap->size(), " samples, the heightfield ", size_t(hf.nx) * size_t(hf.ny));
    }
    StackGeometry g;
    g.nx = hf.nx;
    g.ny = hf.ny;
    g.cell = hf.cellSize;
    g.x0 = -0.5 * hf.cellSize;
    g.y0 = -0.5 * hf.cellSize;
    g.z0 = z0;
    g.quantum = quantum;
    return Stacks::build(g, [&](int i, int j, std::vector<Layer>& layers) {
        const double h = double(hf.at(i, j)) - z0;
        if (h < 0) fail<ValueError>("arches: heightfield sample (", i, ", ", j, ") at ", hf.at(i, j), " m lies below the floor z0 = ", z0, " m");
        const double sand = sandMap ? double((*sandMap)[size_t(j) * size_t(hf.nx) + size_t(i)]) : sandDepth;
        if (!(sand >= 0)) fail<ValueError>("arches: sand map sample (", i, ", ", j, ") is negative");
        const uint32_t top = quanta(h, quantum), s = std::min(top, quanta(sand, quantum));
        layers.push_back(Layer{Material::Bedrock, top - s});
        layers.push_back(Layer{Material::Sand, s});
    }, task);
}

Stacks stacksFromStrata(const StrataSpec& spec, Task& task)
{
    const auto& g = spec.geometry;
    g.validate();
    if (spec.strata.empty()) fail<ValueError>("arches: strata: at least one stratum is needed");
    for (size_t k = 0; k < spec.strata.size(); ++k) {
        if (!(spec.strata[k].thickness >= 0) || !std::isfinite(spec.strata[k].thickness)) {
            fail<ValueError>("arches: strata[", k, "].thickness must be >= 0 (got ", spec.strata[k].thickness, ")");
        }
    }
    noise::Fbm top;
    top.frequency = spec.frequency;
    top.octaves = spec.octaves;
    noise::Fbm warp = top;
    warp.frequency = spec.warpFrequency;
    const double topNorm = spec.amplitude / top.amplitudeSum(), warpNorm = spec.warp / warp.amplitudeSum();
    const size_t n = spec.strata.size();
    return Stacks::build(g, [&](int i, int j, std::vector<Layer>& layers) {
        const float x = float(g.x0 + (i + 0.5) * g.cell), y = float(g.y0 + (j + 0.5) * g.cell);
        const double h = spec.base + topNorm * noise::fbm2(spec.seed, top, x, y) - g.z0;
        if (h <= 0) return;
        // Boundary k (k = 1..n-1) above z0: the strata below it, warped, never below the last.
        double below = 0, nominal = 0;
        uint32_t laid = 0;
        for (size_t k = 0; k < n; ++k) {
            double upper = h;
            if (k + 1 < n) {
                nominal += spec.strata[k].thickness;
                upper = std::min(h, std::max(below, nominal + warpNorm * noise::fbm2(spec.seed + 1 + k, warp, x, y)));
            }
            const uint32_t to = quanta(std::max(upper, 0.0), g.quantum);
            if (to > laid) {
                layers.push_back(Layer{spec.strata[k].material, to - laid});
                laid = to;
            }
            below = std::max(below, upper);
        }
    }, task);
}

Stacks stacksFromSolid(const Field& solid, const StackGeometry& geometry, double step,
                       Material material, Task& task)
{
    geometry.validate();
    if (!(step > 0) || !std::isfinite(step)) fail<ValueError>("arches: sampling step must be > 0 (got ", step, ")");
    const BBoxd b = solid.bounds();
    if (!isBounded(b)) fail<ValueError>("arches: the solid is unbounded; stacks need a top (give a bounded level set or expression)");
    const double z0 = geometry.z0, top = b.max()[2];
    const int samples = top > z0 ? int(std::ceil((top - z0) / step)) + 2 : 0;
    if (samples > 10'000'000) fail<ValueError>("arches: ", samples, " samples per stack; use a larger step");
    const double q = geometry.quantum;
    return Stacks::build(geometry, [&](int i, int j, std::vector<Layer>& layers) {
        const double x = geometry.x0 + (i + 0.5) * geometry.cell, y = geometry.y0 + (j + 0.5) * geometry.cell;
        BatchBuffer batch;
        float values[kMaxBatch];
        // Roots along the axis: where the solid is entered and left (metres above z0).
        double prevZ = 0, prevF = 0;
        bool inside = false;
        uint32_t at = 0; // quanta above z0 already laid
        auto lay = [&](Material m, double z) {
            const uint32_t t = quanta(z, q);
            if (t > at) {
                layers.push_back(Layer{m, t - at});
                at = t;
            }
        };
        for (int k0 = 0; k0 < samples; k0 += kMaxBatch) {
            const int n = std::min(kMaxBatch, samples - k0);
            batch.n = n;
            for (int k = 0; k < n; ++k) {
                batch.x[k] = float(x);
                batch.y[k] = float(y);
                batch.z[k] = float(z0 + (k0 + k) * step);
            }
            solid.evalBatch(batch.view(), values);
            for (int k = 0; k < n; ++k) {
                const double z = (k0 + k) * step, f = double(values[k]);
                const bool in = f < 0;
                if (k0 + k == 0) {
                    inside = in;
                } else if (in != inside) {
                    const double root = prevZ + (z - prevZ) * prevF / (prevF - f);
                    lay(inside ? material : Material::Air, root);
                    inside = in;
                }
                prevZ = z;
                prevF = f;
            }
            task.check();
        }
        if (inside) lay(material, prevZ);
    }, task);
}

} // namespace arches
} // namespace rockvdb
