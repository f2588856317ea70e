// SPDX-License-Identifier: Apache-2.0
// Texture weights from the stacks' exposed faces (see Weights.h).
#include "Weights.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridUtil.h>

#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace rockvdb {
namespace arches {

namespace {

bool ground(uint8_t m)
{
    return (maskOf(Material(m)) & kGroundMask) != 0;
}

} // namespace

ExposedFaces::ExposedFaces(const Stacks& stacks) : mGeometry(stacks.geometry())
{
    const auto& g = mGeometry;
    mFirst.resize(g.count() + 1);
    stacks.forEachStack([&](size_t s, const uint16_t* codes, size_t n) {
        mFirst[s] = uint32_t(mFrom.size());
        uint64_t z = 0;
        for (size_t c = 0; c < n; ++c) {
            const uint8_t m = uint8_t(Stacks::codeMaterial(codes[c]));
            const double a = g.z0 + double(z) * g.quantum;
            z += Stacks::codeThickness(codes[c]);
            const double b = g.z0 + double(z) * g.quantum;
            if (!mMaterial.empty() && mFrom.size() > mFirst[s] && mMaterial.back() == m) {
                mTo.back() = b; // runs of one material merged
                continue;
            }
            mFrom.push_back(a);
            mTo.push_back(b);
            mMaterial.push_back(m);
        }
        // Air above the top.
        mFrom.push_back(g.z0 + double(z) * g.quantum);
        mTo.push_back(std::numeric_limits<double>::infinity());
        mMaterial.push_back(uint8_t(Material::Air));
    });
    mFirst[g.count()] = uint32_t(mFrom.size());
}

void ExposedFaces::areas(const Vec3d& p, double half, double out[kMaterialCount]) const
{
    const auto& g = mGeometry;
    std::fill(out, out + kMaterialCount, 0.0);
    const double xlo = p[0] - half, xhi = p[0] + half, ylo = p[1] - half, yhi = p[1] + half;
    const double zlo = p[2] - half, zhi = p[2] + half;
    const int i0 = int(std::floor((xlo - g.x0) / g.cell)), i1 = int(std::floor((xhi - g.x0) / g.cell));
    const int j0 = int(std::floor((ylo - g.y0) / g.cell)), j1 = int(std::floor((yhi - g.y0) / g.cell));
    auto inside = [&](int i, int j) { return i >= 0 && j >= 0 && i < g.nx && j < g.ny; };
    static const double kInf = std::numeric_limits<double>::infinity();
    // A stack's intervals; outside the grid, air everywhere.
    auto range = [&](int i, int j, uint32_t& a, uint32_t& b) {
        if (!inside(i, j)) {
            a = b = 0;
            return;
        }
        const size_t s = g.index(i, j);
        a = mFirst[s];
        b = mFirst[s + 1];
    };
    // Horizontal faces: boundaries between a ground material and air or water, in the cube.
    for (int j = std::max(j0, 0); j <= std::min(j1, g.ny - 1); ++j) {
        const double wy = std::min(yhi, g.y0 + (j + 1) * g.cell) - std::max(ylo, g.y0 + j * g.cell);
        if (wy <= 0) continue;
        for (int i = std::max(i0, 0); i <= std::min(i1, g.nx - 1); ++i) {
            const double wx = std::min(xhi, g.x0 + (i + 1) * g.cell) - std::max(xlo, g.x0 + i * g.cell);
            if (wx <= 0) continue;
            uint32_t a, b;
            range(i, j, a, b);
            for (uint32_t k = a + 1; k < b; ++k) {
                const double z = mFrom[k];
                if (z <= zlo || z >= zhi) continue;
                const uint8_t below = mMaterial[k - 1], above = mMaterial[k];
                if (ground(below) && !ground(above)) out[below] += wx * wy;
                else if (!ground(below) && ground(above)) out[above] += wx * wy;
            }
        }
    }
    // Vertical faces between neighbours (i, j) | (i + 1, j) and (i, j) | (i, j + 1): along the
    // shared face, where one side is ground and the other is not, the ground side shows.
    auto side = [&](int ia, int ja, int ib, int jb, double length) {
        // Every stack's intervals cover [z0, ∞) (outside the grid: air); nothing shows below z0.
        double z = std::max(zlo, g.z0);
        if (z >= zhi) return;
        uint32_t a0, a1, b0, b1;
        range(ia, ja, a0, a1);
        range(ib, jb, b0, b1);
        uint32_t ka = a0, kb = b0;
        while (ka < a1 && mTo[ka] <= z) ++ka;
        while (kb < b1 && mTo[kb] <= z) ++kb;
        while (z < zhi) {
            const uint8_t ma = ka < a1 ? mMaterial[ka] : uint8_t(Material::Air);
            const uint8_t mb = kb < b1 ? mMaterial[kb] : uint8_t(Material::Air);
            const double next = std::min({ka < a1 ? mTo[ka] : kInf, kb < b1 ? mTo[kb] : kInf, zhi});
            if (ground(ma) && !ground(mb)) out[ma] += (next - z) * length;
            else if (ground(mb) && !ground(ma)) out[mb] += (next - z) * length;
            z = next;
            while (ka < a1 && mTo[ka] <= z) ++ka;
            while (kb < b1 && mTo[kb] <= z) ++kb;
        }
    };
    // Faces at x = x0 + (i + 1)·s inside the cube.
    for (int i = i0 - 1; i <= i1; ++i) {
        const double xf = g.x0 + (i + 1) * g.cell;
        if (xf <= xlo || xf >= xhi) continue;
        for (int j = j0; j <= j1; ++j) {
            const double wy = std::min(yhi, g.y0 + (j + 1) * g.cell) - std::max(ylo, g.y0 + j * g.cell);
            if (wy <= 0 || (!inside(i, j) && !inside(i + 1, j))) continue;
            side(i, j, i + 1, j, wy);
        }
    }
    for (int j = j0 - 1; j <= j1; ++j) {
        const double yf = g.y0 + (j + 1) * g.cell;
        if (yf <= ylo || yf >= yhi) continue;
        for (int i = i0; i <= i1; ++i) {
            const double wx = std::min(xhi, g.x0 + (i + 1) * g.cell) - std::max(xlo, g.x0 + i * g.cell);
            if (wx <= 0 || (!inside(i, j) && !inside(i, j + 1))) continue;
            side(i, j, i, j + 1, wx);
        }
    }
}

std::vector<openvdb::FloatGrid::Ptr> visibleWeights(const Stacks& stacks, const std::vector<Material>& materials,
                                                    double sigma, const openvdb::FloatGrid& surface, Task& task)
{
    const ExposedFaces faces(stacks);
    std::vector<openvdb::FloatGrid::Ptr> out;
    for (const Material m : materials) {
        auto g = openvdb::FloatGrid::create(0.0f);
        g->setTransform(surface.transform().copy());
        g->setName(std::string("weight_") + materialName(m));
        g->setGridClass(openvdb::GRID_FOG_VOLUME);
        g->tree().topologyUnion(surface.tree());
        out.push_back(g);
    }
    if (out.empty()) return out;
    std::vector<std::unique_ptr<openvdb::tree::LeafManager<openvdb::FloatTree>>> managers;
    for (auto& g : out) managers.push_back(std::make_unique<openvdb::tree::LeafManager<openvdb::FloatTree>>(g->tree()));
    const size_t leaves = managers[0]->leafCount();
    const auto& xf = surface.transform();
    const double dx = surface.voxelSize()[0];
    parallelFor(task, leaves, 8, [&](size_t l) {
        openvdb::tree::ValueAccessor<const openvdb::FloatTree> acc(surface.tree());
        double a[kMaterialCount];
        auto& first = managers[0]->leaf(l);
        for (auto it = first.beginValueOn(); it; ++it) {
            const openvdb::Coord c = it.getCoord();
            // At the voxel's closest surface point p − φ∇φ (a cube of half size max(σ, dx)):
            // the same few stacks for every voxel of the band, where a cube grown to reach the
            // surface (σ + |φ|) held ~10x more at the band's edge.
            const double phi = acc.getValue(c);
            const Vec3d grad(acc.getValue(c.offsetBy(1, 0, 0)) - acc.getValue(c.offsetBy(-1, 0, 0)),
                             acc.getValue(c.offsetBy(0, 1, 0)) - acc.getValue(c.offsetBy(0, -1, 0)),
                             acc.getValue(c.offsetBy(0, 0, 1)) - acc.getValue(c.offsetBy(0, 0, -1)));
            const double len = grad.length();
            const Vec3d p = xf.indexToWorld(c);
            if (len > 1e-12) faces.areas(p - grad * (phi / len), std::max(sigma, dx), a);
            else faces.areas(p, sigma + std::abs(phi), a);
            double total = 0;
            for (int m = 0; m < kMaterialCount; ++m) {
                if (maskOf(Material(m)) & kGroundMask) total += a[m];
            }
            for (size_t k = 0; k < materials.size(); ++k) {
                const float w = total > 0 ? float(a[size_t(materials[k])] / total) : 0.0f;
                managers[k]->leaf(l).setValueOnly(it.pos(), w);
            }
        }
    });
    return out;
}

} // namespace arches
} // namespace rockvdb
