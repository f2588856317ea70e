// rockvdb — material stacks (Arches: "Arches: a Framework for Modeling Complex Terrains", §3.2).
//
// A terrain is a 2D grid of stacks, cell size s; each stack is an ordered list of layers
// (material, thickness) from a common floor z0 upwards; above its last layer a stack holds air.
// An air layer between two bedrock layers is an overhang, an arch or a cave.
//
// Storage is the point of the model (the paper stores 6 billion effective voxels in 21 MB):
// one contiguous array of 16-bit layer codes — material in the top 3 bits, thickness in the
// low 13 bits, in quanta of q metres — a code count per stack (one byte) and a 32-bit offset
// per block of 64 stacks: ~1.06 + 2·L bytes for a stack of L layers (a stack's first code is
// its block's offset plus the counts before it in the block, at most 63 bytes to add). A
// layer thicker than 8 191 quanta is stored as a run of codes of the same material, which
// decoding merges; a stack holds at most 255 codes. Thickness accounting is in whole quanta, so the volume of
// every material is an integer the stabilisation conserves exactly.
#pragma once

#include <rockvdb/core/Field.h>
#include <rockvdb/core/Task.h>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace rockvdb {
namespace arches {

/// The materials of §3.2; their values are the ids written in 'material' grids.
enum class Material : uint8_t { Air = 0, Water = 1, Sand = 2, Bedrock = 3, Rocks = 4 };
constexpr int kMaterialCount = 5;

/// @brief "air", "water", "sand", "bedrock", "rocks".
const char* materialName(Material m);
/// @brief The material named @a name. @throw ValueError naming @a what and the known names.
Material materialFromName(const std::string& name, const std::string& what);

/// A set of materials (bit m for Material m): a convolution's skeleton.
using MaterialMask = uint8_t;
constexpr MaterialMask maskOf(Material m) { return MaterialMask(1u << unsigned(m)); }
/// The ground of §6: sand ∪ bedrock ∪ rocks.
constexpr MaterialMask kGroundMask = maskOf(Material::Sand) | maskOf(Material::Bedrock) | maskOf(Material::Rocks);

/// One layer: a material and a thickness in quanta.
struct Layer
{
    Material material = Material::Air;
    uint32_t thickness = 0;
    bool operator==(const Layer& o) const { return material == o.material && thickness == o.thickness; }
};

/// Where the stacks are: stack (i, j) covers [x0 + i·s, x0 + (i+1)·s) × [y0 + j·s, y0 + (j+1)·s)
/// and its layers start at z0; thicknesses are in quanta of q metres.
struct StackGeometry
{
    int nx = 0, ny = 0;
    double cell = 1.0;    ///< s (m)
    double x0 = 0, y0 = 0, z0 = 0;
    double quantum = 0.01; ///< q (m)

    /// @brief ValueError unless the sizes are positive and finite.
    void validate() const;
    size_t count() const { return size_t(nx) * size_t(ny); }
    size_t index(int i, int j) const { return size_t(j) * size_t(nx) + size_t(i); }
    bool operator==(const StackGeometry& o) const;
};

class Stacks
{
public:
    /// Largest thickness one code holds (quanta); thicker layers become runs.
    static constexpr uint32_t kMaxCode = (1u << 13) - 1;

    Stacks() = default;

    /// @brief Build every stack from @a column(i, j, layers) — called in parallel, rows at a
    /// time, with an empty vector to fill bottom first; zero thicknesses are dropped and
    /// neighbours of the same material merged. The result does not depend on thread count.
    /// @throw ValueError when even one layer per stack would exceed @a maxMemoryBytes (0: 75%
    /// of RAM), with the estimate, before allocating.
    static Stacks build(const StackGeometry& geometry,
                        const std::function<void(int i, int j, std::vector<Layer>& layers)>& column,
                        Task& task, double maxMemoryBytes = 0);

    const StackGeometry& geometry() const { return mGeometry; }

    /// @brief The layers of stack (i, j), bottom first, runs merged.
    void layers(int i, int j, std::vector<Layer>& out) const;
    /// Number of codes in stack (i, j) (its stored layers).
    size_t codeCount(int i, int j) const { return mCount[mGeometry.index(i, j)]; }
    /// Index of stack s's first code.
    size_t begin(size_t s) const
    {
        size_t b = mBlock[s >> kBlockBits];
        for (size_t t = s & ~kBlockMask; t < s; ++t) b += mCount[t];
        return b;
    }
    /// @brief Height of stack (i, j)'s top (quanta above z0).
    uint64_t height(int i, int j) const;

    /// Total thickness of @a m over all stacks (quanta · stacks): volume / (s² q).
    uint64_t volumeQuanta(Material m) const;
    /// Bytes the stacks occupy (codes, counts and block offsets).
    size_t bytes() const
    {
        return mCode.size() * sizeof(uint16_t) + mCount.size() + mBlock.size() * sizeof(uint32_t);
    }
    size_t layerCount() const { return mCode.size(); }

    bool operator==(const Stacks& o) const
    {
        return mGeometry == o.mGeometry && mCode == o.mCode && mCount == o.mCount;
    }

    /// The raw encoding (for files and numpy views): the codes, and the codes per stack.
    const std::vector<uint16_t>& codes() const { return mCode; }
    const std::vector<uint8_t>& counts() const { return mCount; }
    /// @brief Stacks from a raw encoding. @throw ValueError if it is inconsistent.
    static Stacks fromEncoding(const StackGeometry& geometry, std::vector<uint16_t> codes,
                               std::vector<uint8_t> counts);

    static Material codeMaterial(uint16_t c) { return Material(c >> 13); }
    static uint32_t codeThickness(uint16_t c) { return c & kMaxCode; }
    static uint16_t code(Material m, uint32_t t) { return uint16_t((unsigned(m) << 13) | t); }

private:
    static constexpr size_t kBlockBits = 6, kBlockMask = (size_t(1) << kBlockBits) - 1;
    void index(); // mBlock from mCount

    StackGeometry mGeometry;
    std::vector<uint16_t> mCode;
    std::vector<uint8_t> mCount;   // codes per stack
    std::vector<uint32_t> mBlock;  // first code of each block of 64 stacks
};

/// @brief A skeleton (§3.3): per stack, the z intervals where the stack holds a material of
/// @a mask, decoded once (metres) with the covered length below each interval, so that the
/// length of skeleton in [z_lo, z_hi] of one stack costs two binary searches.
class Skeleton
{
public:
    Skeleton(const Stacks& stacks, MaterialMask mask);

    const StackGeometry& geometry() const { return mGeometry; }
    MaterialMask mask() const { return mMask; }

    /// @brief Length of skeleton within [zlo, zhi] in stack s (zlo <= zhi).
    double covered(size_t s, double zlo, double zhi) const { return below(s, zhi) - below(s, zlo); }
    /// @brief Length of skeleton below z in stack s.
    double below(size_t s, double z) const;

    /// @brief V_M(p): the skeleton's volume inside the cube ‖q − p‖∞ < σ (stacks outside the
    /// grid hold nothing).
    double volume(const Vec3d& p, double sigma) const;
    /// @brief The convolution field f(p) = V_M / (4σ³) − 1 of §3.3: 1 deep inside, −1 far
    /// outside, 0 where the cube is half full.
    double field(const Vec3d& p, double sigma) const { return volume(p, sigma) / (4.0 * sigma * sigma * sigma) - 1.0; }

    /// Intervals of stack s: [start, end) pairs (metres), bottom first.
    size_t intervalCount(size_t s) const { return mFirst[s + 1] - mFirst[s]; }
    double start(size_t s, size_t k) const { return mStart[mFirst[s] + k]; }
    double end(size_t s, size_t k) const { return mEnd[mFirst[s] + k]; }

private:
    StackGeometry mGeometry;
    MaterialMask mMask;
    std::vector<uint32_t> mFirst;      // per stack: its first interval
    std::vector<double> mStart, mEnd;  // interval bounds (m)
    std::vector<double> mBefore;       // covered length below each interval's start
};

} // namespace arches
} // namespace rockvdb
