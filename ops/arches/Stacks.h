// SPDX-License-Identifier: Apache-2.0
// rockvdb — material stacks (Arches: "Arches: a Framework for Modeling Complex Terrains", §3.2).
//
// A terrain is a 2D grid of stacks, cell size s; each stack is an ordered list of layers
// (material, thickness) from a common floor z0 upwards; above its last layer a stack holds air.
// An air layer between two bedrock layers is an overhang, an arch or a cave.
//
// Storage is the point of the model (the paper stores 6 billion effective voxels in 21 MB).
// A layer is a 16-bit code — material (3 bits) and thickness (up to 4 095 quanta of q metres;
// thicker layers are runs of codes, which decoding merges) — and the codes are stored as a
// byte stream, delta-coded against the stack before: a code whose material matches the
// previous stack's code at the same place and whose thickness is within −64..63 of it takes
// one byte (0ddddddd), any other two (1mmmtttt tttttttt). Neighbouring stacks of a terrain
// mostly have the same strata a little thicker or thinner, so most layers take one byte.
// Per stack a code count (one byte, at most 255 codes); per block of 64 stacks the byte offset
// of its first stack, which is coded in full: a stack is decoded from its block's start.
// About 1.06 + ~1.1·L bytes for a stack of L layers. Thickness accounting is in whole quanta,
// so the volume of every material is an integer the stabilisation conserves exactly.
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
    static constexpr uint32_t kMaxCode = 4095;

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

    /// @brief The stacks in [i0, i1] × [j0, j1] (clipped to the grid; at least one stack) as
    /// stacks of their own, their origin moved to the window's corner: what a local edit reads.
    Stacks window(int i0, int j0, int i1, int j1, Task& task) const;
    /// @brief Rewrite stacks in place: @a change gets every stack of [i0, i1] × [j0, j1]
    /// (clipped) as layers (runs merged, bottom first) and returns true when it changed them.
    /// Only the 64-stack blocks holding a changed stack are re-encoded and spliced into the
    /// stream, so the cost follows the window (plus one copy of the stream when anything
    /// changed). Returns the number of stacks changed. @throw ValueError as build does (the
    /// stacks are then unchanged).
    size_t edit(int i0, int j0, int i1, int j1,
                const std::function<bool(int i, int j, std::vector<Layer>& layers)>& change);

    /// @brief The layers of stack (i, j), bottom first, runs merged (decodes its block up to it).
    void layers(int i, int j, std::vector<Layer>& out) const;
    /// Number of codes in stack (i, j) (its stored layers).
    size_t codeCount(int i, int j) const { return mCount[mGeometry.index(i, j)]; }
    /// @brief Height of stack (i, j)'s top (quanta above z0).
    uint64_t height(int i, int j) const;

    /// @brief Visit every stack in index order (s = j·nx + i) with its codes (runs unmerged):
    /// the sequential decoding that whole-terrain passes use.
    void forEachStack(const std::function<void(size_t s, const uint16_t* codes, size_t n)>& visit) const;

    /// Total thickness of @a m over all stacks (quanta · stacks): volume / (s² q).
    uint64_t volumeQuanta(Material m) const;
    /// Bytes the stacks occupy (code stream, counts and block offsets).
    size_t bytes() const { return mStream.size() + mCount.size() + mBlock.size() * sizeof(uint32_t); }
    /// Number of codes over all stacks.
    size_t layerCount() const { return mCodes; }

    bool operator==(const Stacks& o) const
    {
        return mGeometry == o.mGeometry && mStream == o.mStream && mCount == o.mCount;
    }

    /// The encoding (for files): the byte stream and the codes per stack.
    const std::vector<uint8_t>& stream() const { return mStream; }
    const std::vector<uint8_t>& counts() const { return mCount; }
    /// @brief Stacks from an encoding. @throw ValueError if it does not decode exactly.
    static Stacks fromEncoding(const StackGeometry& geometry, std::vector<uint8_t> stream,
                               std::vector<uint8_t> counts);

    static Material codeMaterial(uint16_t c) { return Material(c >> 13); }
    static uint32_t codeThickness(uint16_t c) { return c & 0x1fffu; }
    static uint16_t code(Material m, uint32_t t) { return uint16_t((unsigned(m) << 13) | t); }

private:
    static constexpr size_t kBlock = 64;
    // Decode stack s's codes from the stream at @a at, given the previous stack's (empty for a
    // block's first); returns the position after them. @throw ValueError if malformed.
    static size_t decodeStack(const std::vector<uint8_t>& stream, size_t at, size_t n,
                              const std::vector<uint16_t>& prev, std::vector<uint16_t>& out);
    static void encodeStack(const std::vector<uint16_t>& prev, const uint16_t* codes, size_t n,
                            std::vector<uint8_t>& out);
    // Append stack (i, j)'s codes for @a layers (zero thicknesses dropped, neighbours of one
    // material merged, runs split at kMaxCode, air on top dropped); returns how many.
    // @throw ValueError for an unknown material or more than 255 codes.
    static size_t appendCodes(int i, int j, const std::vector<Layer>& layers, std::vector<uint16_t>& codes);
    void decodeUpTo(size_t s, std::vector<uint16_t>& out) const;

    StackGeometry mGeometry;
    std::vector<uint8_t> mStream;
    std::vector<uint8_t> mCount;  // codes per stack
    std::vector<uint32_t> mBlock; // stream offset of each block of 64 stacks
    size_t mCodes = 0;
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

    /// @brief Stack s's feature size at height @a z: over its pieces (intervals, and the gaps
    /// between them), the least half length plus z's distance from the piece (+∞ where none
    /// is bounded).
    double featureSize(size_t s, double z) const;
    /// @brief rockvdb's interpolating reconstruction (a departure from §3.3, see StackBake.h):
    /// with ρ = min(@a reach, max(σ, the least featureSize of the stacks under the square
    /// ‖q − p‖∞ < σ in xy)), the mean over those stacks, weighted by the area each one's cell
    /// shares with the square (outside the grid: empty), of ρ − (length of skeleton within ρ
    /// of z). That is the vertical distance to the stack's boundary clamped to ±ρ where one
    /// boundary is within ρ, and −σ·f (the box) where ρ = σ. Negative inside; with σ = s/2 the
    /// bilinear interpolation between the four nearest stacks, exact for planar walls whose
    /// heights differ by less than ρ under the square.
    double interpolated(const Vec3d& p, double sigma, double reach) const;

    /// The highest interval end (m), z0 when the skeleton is empty.
    double top() const;

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
