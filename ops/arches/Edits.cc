// SPDX-License-Identifier: Apache-2.0
// Editing material stacks (see Edits.h).
#include "Edits.h"
#include "Sweep.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Schema.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <vector>

namespace rockvdb {
namespace arches {

using json = nlohmann::json;

namespace {

// A key of a tool: its JSON type, default (null: none, or computed as its help says), help,
// whether an edit must give it, the range of a number and the values of a string. The one
// place a key's default lives: withDefaults() fills it in before an edit runs.
struct Key
{
    std::string name, type;
    json def;
    std::string help;
    bool required = false;
    Range range;
    std::vector<std::string> choices;
};

struct Tool
{
    std::string help;
    std::vector<Key> keys;
};

Key key(const char* name, const char* type, json def, std::string help, bool required = false)
{
    return {name, type, std::move(def), std::move(help), required, Range::any(), {}};
}

Key numberKey(const char* name, json def, Range range, std::string help, bool required = false)
{
    return {name, "number", std::move(def), std::move(help), required, range, {}};
}

Key choiceKey(const char* name, std::vector<std::string> choices, std::string help)
{
    const json def = choices.front();
    return {name, "string", def, std::move(help), false, Range::any(), std::move(choices)};
}

std::map<std::string, Tool> makeTools()
{
    std::map<std::string, Tool> t;
    t["sculpt"] = {
        "Displace the bedrock along its normal with a point primitive (§4.1), at each point of a stroke",
        {key("points", "points", nullptr, "Targets [[x, y, z], ...] (m), projected on the bedrock surface in turn "
                                           "(with at = center: the primitive's centres themselves)", true),
         numberKey("radius", nullptr, Range::above(0), "R: the primitive's radius of influence (m)", true),
         choiceKey("mode", {"add", "carve"}, "add (bedrock grows out) or carve (bedrock is cut in)"),
         numberKey("depth", nullptr, Range::atLeast(0), "delta: the centre lies this far inside (add) or outside "
                                                       "(carve) the surface (m, at most R; default R/2)"),
         numberKey("strength", 1.0, Range::above(0), "k in f_e = f +- k g(r) (1 as in the paper, larger cuts or adds deeper)"),
         choiceKey("at", {"surface", "center"}, "surface (points are targets on the bedrock) or center (points are centres)")}};
    t["deposit"] = {
        "Drop sand or rocks over a disc, then stabilise (§4.3)",
        {key("center", "xy", nullptr, "[x, y] of the disc (m)", true),
         numberKey("radius", nullptr, Range::above(0), "R: the disc's radius (m)", true),
         numberKey("amount", nullptr, Range::above(0), "Thickness dropped at the centre (m)", true),
         choiceKey("material", {"sand", "rocks"}, "sand or rocks"),
         choiceKey("profile", {"smooth", "flat"}, "smooth: amount (1 - (r/R)^2)^2, or flat: amount over the disc"),
         numberKey("z", nullptr, Range::any(), "Drop into the room (between bedrock) holding this height, e.g. a cave's "
                                             "floor (m; default: on each stack's top)")}};
    t["erode"] = {
        "Turn bedrock inside a sphere, or the tube a sphere sweeps along a stroke, into granular material, "
        "then stabilise (§4.4)",
        {key("center", "xyz", nullptr, "[x, y, z] of the sphere (m; or points)"),
         numberKey("radius", nullptr, Range::above(0), "R: the sphere's radius (m)", true),
         key("points", "points", nullptr, "A stroke [[x, y, z], ...] (m): the region is the sphere swept along its "
                                          "segments (or center)"),
         choiceKey("mode", {"surface", "collapse"}, "surface: the bedrock within depth of an exposed face turns to sand; "
                                                 "collapse: all the bedrock in the sphere turns to rocks and sand"),
         numberKey("depth", nullptr, Range::above(0), "surface mode: thickness eroded below each exposed face (m; "
                                                     "default one cell)"),
         numberKey("rho", 0.5, Range::closed(0, 1), "collapse mode: the share of rocks (the rest is sand)")}};
    // crack and tunnel (§4.2): a graph and a profile swept along it; they differ in their
    // nodes (2D, projected on the terrain, or 3D) and in what the profile's v means.
    auto sweepTool = [](const char* help, Key nodes, const char* profileV) {
        return Tool{help,
            {std::move(nodes),
             key("arcs", "arcs", nullptr, "Arcs between nodes [[a, b], ...] (indices; default: a path through the "
                                          "nodes in order)"),
             key("profile", "profile", nullptr, std::string("The cross-section: closed curve through [[u, v], ...] (m; "
                                                            "u across, v along the normal, >= 3 points, non-convex "
                                                            "allowed), at every node; ") + profileV),
             key("profiles", "profiles", nullptr, "Several profiles [[[u, v], ...], ...], chosen per node by node_profiles"),
             key("node_profiles", "ints", nullptr, "Per node: the index of its profile in profiles (interpolated along arcs)"),
             key("spline", "bool", true, "Profiles as closed cubic splines through their points (false: polygons)"),
             numberKey("step", nullptr, Range::above(0), "Spacing of cross-sections along arcs (m; default one cell)")}};
    };
    t["crack"] = sweepTool("Carve a crack or ravine: a graph projected on the terrain, a profile swept along it (§4.2)",
                           key("nodes", "points23", nullptr, "Nodes [[x, y], ...] (m), projected down on the ground's "
                                                             "bedrock top, or [[x, y, z], ...], projected on the bedrock "
                                                             "surface nearest to them (a cliff face, an overhang's "
                                                             "underside: within 4 sigma)", true),
                           "v > 0 is above the surface");
    t["tunnel"] = sweepTool("Carve tunnels and caves: a graph in 3D, a profile swept along it (§4.2)",
                            key("nodes", "points", nullptr, "Nodes [[x, y, z], ...] (m)", true), "v is up");
    t["stabilize"] = {"Stabilise every stack (§3.4), as the scene's stabilize does before the edits", {}};
    return t;
}

const std::map<std::string, Tool>& tools()
{
    static const std::map<std::string, Tool> t = makeTools();
    return t;
}

[[noreturn]] void bad(size_t index, const std::string& tool, const std::string& what)
{
    fail<ValueError>("arches: edits[", index, "] (", tool, "): ", what);
}

double number(const json& e, const char* k, size_t index, const std::string& tool)
{
    const json& v = e.at(k);
    if (!v.is_number()) bad(index, tool, std::string(k) + " must be a number");
    const double d = v.get<double>();
    if (!std::isfinite(d)) bad(index, tool, std::string(k) + " must be finite");
    return d;
}

std::vector<double> vec(const json& v, size_t n, const std::string& what, size_t index, const std::string& tool)
{
    if (!v.is_array() || v.size() != n) bad(index, tool, what + " must be a list of " + std::to_string(n) + " numbers");
    std::vector<double> out;
    for (const auto& x : v) {
        if (!x.is_number() || !std::isfinite(x.get<double>())) {
            bad(index, tool, what + " must be a list of " + std::to_string(n) + " numbers");
        }
        out.push_back(x.get<double>());
    }
    return out;
}

std::vector<Vec2d> profileOf(const json& v, const std::string& what, size_t index, const std::string& tool)
{
    if (!v.is_array() || v.size() < 3) {
        bad(index, tool, what + " needs at least 3 points [[u, v], ...] (got " + std::to_string(v.is_array() ? v.size() : 0) + ")");
    }
    std::vector<Vec2d> out;
    for (size_t q = 0; q < v.size(); ++q) {
        const auto uv = vec(v[q], 2, what + "[" + std::to_string(q) + "]", index, tool);
        out.emplace_back(uv[0], uv[1]);
    }
    return out;
}

// ---- stacks as intervals ---------------------------------------------------------------------

uint64_t quantaAt(const StackGeometry& g, double z)
{
    const double q = (z - g.z0) / g.quantum;
    if (q <= 0) return 0;
    return uint64_t(std::llround(std::min(q, 4e18)));
}

// Rewrite [lo, hi) (quanta) of a stack: every piece of it (split at the layer boundaries and at
// @a cuts) becomes material(original material, piece start, piece end). Above the stack's
// top the original is air.
void overwrite(std::vector<Layer>& layers, uint64_t lo, uint64_t hi, std::vector<uint64_t> cuts,
               const std::function<Material(Material, uint64_t, uint64_t)>& material)
{
    if (lo >= hi) return;
    uint64_t top = 0;
    for (const Layer& l : layers) top += l.thickness;
    if (hi > top) layers.push_back(Layer{Material::Air, uint32_t(0)}); // extended below
    std::vector<Layer> out;
    uint64_t z = 0;
    auto emit = [&](Material m, uint64_t t) {
        while (t > 0) {
            const uint32_t part = uint32_t(std::min<uint64_t>(t, 0xffffffffu));
            if (!out.empty() && out.back().material == m && uint64_t(out.back().thickness) + part <= 0xffffffffu) {
                out.back().thickness += part;
            } else {
                out.push_back(Layer{m, part});
            }
            t -= part;
        }
    };
    cuts.push_back(lo);
    cuts.push_back(hi);
    std::sort(cuts.begin(), cuts.end());
    for (size_t k = 0; k < layers.size(); ++k) {
        const Layer& l = layers[k];
        const uint64_t a = z;
        const uint64_t b = (k + 1 == layers.size() && hi > top) ? std::max<uint64_t>(hi, z + l.thickness) : z + l.thickness;
        z = b;
        if (b <= lo || a >= hi) {
            emit(l.material, b - a);
            continue;
        }
        // Pieces of [a, b): outside [lo, hi) as they are, inside split at the cuts.
        uint64_t at = a;
        if (at < lo) {
            emit(l.material, lo - at);
            at = lo;
        }
        const uint64_t end = std::min(b, hi);
        for (const uint64_t c : cuts) {
            if (c <= at || c >= end) continue;
            emit(material(l.material, at, c), c - at);
            at = c;
        }
        emit(material(l.material, at, end), end - at);
        if (end < b) emit(l.material, b - end);
    }
    layers.swap(out);
}

int64_t quantaOf(const std::vector<Layer>& layers, Material m)
{
    int64_t n = 0;
    for (const Layer& l : layers) {
        if (l.material == m) n += int64_t(l.thickness);
    }
    return n;
}

// Stacks whose axis lies within r (horizontally) of (x, y): the index window holding them.
void axisWindow(const StackGeometry& g, double x, double y, double r, int& i0, int& j0, int& i1, int& j1)
{
    i0 = int(std::ceil((x - r - g.x0) / g.cell - 0.5));
    i1 = int(std::floor((x + r - g.x0) / g.cell - 0.5));
    j0 = int(std::ceil((y - r - g.y0) / g.cell - 0.5));
    j1 = int(std::floor((y + r - g.y0) / g.cell - 0.5));
    i0 = std::max(i0, 0);
    j0 = std::max(j0, 0);
    i1 = std::min(i1, g.nx - 1);
    j1 = std::min(j1, g.ny - 1);
}

void requireInside(const StackGeometry& g, double x, double y, size_t index, const std::string& tool, const char* what)
{
    const double x1 = g.x0 + g.nx * g.cell, y1 = g.y0 + g.ny * g.cell;
    if (!(x >= g.x0 && x <= x1 && y >= g.y0 && y <= y1)) {
        bad(index, tool, std::string(what) + " (" + std::to_string(x) + ", " + std::to_string(y) +
                             ") is outside the terrain [" + std::to_string(g.x0) + ", " + std::to_string(x1) + "] x [" +
                             std::to_string(g.y0) + ", " + std::to_string(y1) + "]");
    }
}

struct Touched
{
    int i0 = std::numeric_limits<int>::max(), j0 = std::numeric_limits<int>::max(), i1 = -1, j1 = -1;
    void add(int i, int j)
    {
        i0 = std::min(i0, i);
        j0 = std::min(j0, j);
        i1 = std::max(i1, i);
        j1 = std::max(j1, j);
    }
    bool any() const { return i1 >= 0; }
};

// ---- sculpt (§4.1) ---------------------------------------------------------------------------

// One point of a stroke: the bedrock field f of the stacks around it, the target projected on
// its surface, the primitive's centre, and the stacks within R re-split by the roots of f_e.
void sculptPoint(Stacks& stacks, const std::vector<double>& v, double R, bool add, double delta, double k,
                 bool atCenter, const EditContext& ctx, size_t index, Touched& touched, EditStats& st, Task& task)
{
    const auto& g = stacks.geometry();
    const double sigma = ctx.sigma;
    // The field's window: every stack whose cell the σ-cubes can meet around the stacks within
    // R of the centre, which lies up to δ <= R from the target.
    const double reach = 2.0 * R + 2.0 * sigma + g.cell;
    int wi0, wj0, wi1, wj1;
    axisWindow(g, v[0], v[1], reach + 2.0 * g.cell, wi0, wj0, wi1, wj1);
    const Stacks win = stacks.window(wi0, wj0, wi1, wj1, task);
    const Skeleton bedrock(win, maskOf(Material::Bedrock));
    auto f = [&](const Vec3d& p) { return bedrock.field(p, sigma); };
    Vec3d c(v[0], v[1], v[2]);
    if (!atCenter) {
        // Project v on the bedrock surface: the bedrock boundary (a top or an underside) of
        // v's stack nearest v, then the root of f near it along the vertical.
        const int i = std::clamp(int(std::floor((v[0] - g.x0) / g.cell)), 0, g.nx - 1);
        const int j = std::clamp(int(std::floor((v[1] - g.y0) / g.cell)), 0, g.ny - 1);
        std::vector<Layer> layers;
        stacks.layers(i, j, layers);
        double best = std::numeric_limits<double>::infinity(), z = 0;
        uint64_t at = 0;
        bool prevBedrock = false;
        for (size_t l = 0; l <= layers.size(); ++l) {
            const bool isBedrock = l < layers.size() && layers[l].material == Material::Bedrock;
            if (isBedrock != prevBedrock) {
                const double zb = g.z0 + double(at) * g.quantum;
                if (std::abs(zb - v[2]) < best) {
                    best = std::abs(zb - v[2]);
                    z = zb;
                }
            }
            if (l < layers.size()) at += layers[l].thickness;
            prevBedrock = isBedrock;
        }
        if (!std::isfinite(best)) bad(index, "sculpt", "no bedrock under the target (" + std::to_string(v[0]) + ", " +
                                                           std::to_string(v[1]) + ")");
        // Refine: f's sign change within ±σ of the boundary, by bisection.
        double lo = z - sigma, hi = z + sigma;
        double flo = f(Vec3d(v[0], v[1], lo)), fhi = f(Vec3d(v[0], v[1], hi));
        if ((flo > 0) != (fhi > 0)) {
            for (int it = 0; it < 40; ++it) {
                const double mid = 0.5 * (lo + hi), fm = f(Vec3d(v[0], v[1], mid));
                if ((fm > 0) == (flo > 0)) {
                    lo = mid;
                    flo = fm;
                } else {
                    hi = mid;
                }
            }
            z = 0.5 * (lo + hi);
        }
        const Vec3d p(v[0], v[1], z);
        // The outward normal: f falls outward (1 inside, −1 outside).
        const double h = 0.5 * sigma;
        Vec3d grad(f(p + Vec3d(h, 0, 0)) - f(p - Vec3d(h, 0, 0)), f(p + Vec3d(0, h, 0)) - f(p - Vec3d(0, h, 0)),
                   f(p + Vec3d(0, 0, h)) - f(p - Vec3d(0, 0, h)));
        Vec3d n = -grad;
        const double len = n.length();
        if (len > 1e-12) {
            n /= len;
        } else {
            // Flat to the probe: up from a top, down from an underside.
            n = Vec3d(0, 0, f(p - Vec3d(0, 0, h)) > 0 ? 1.0 : -1.0);
        }
        c = add ? p - delta * n : p + delta * n;
    }
    // f_e = f ± k·g(‖p − c‖); the stacks whose axis is within R of c.
    auto fe = [&](const Vec3d& p) {
        const double r2 = (p - c).lengthSqr() / (R * R);
        const double gr = r2 < 1.0 ? (1.0 - r2) * (1.0 - r2) : 0.0;
        return f(p) + (add ? k : -k) * gr;
    };
    int i0, j0, i1, j1;
    axisWindow(g, c[0], c[1], R, i0, j0, i1, j1);
    // f is piecewise linear along an axis (kinks where interval ends ± σ pass): samples every
    // σ/2, roots by linear interpolation.
    const double step = std::max(g.quantum, 0.5 * std::min(sigma, R));
    task.check();
    size_t visited = 0;
    st.stacks += stacks.edit(i0, j0, i1, j1, [&](int i, int j, std::vector<Layer>& layers) {
        if ((++visited & 63) == 0) task.check(); // a big stroke or sweep stays interruptible
        const double x = g.x0 + (i + 0.5) * g.cell, y = g.y0 + (j + 0.5) * g.cell;
        const double d2 = (x - c[0]) * (x - c[0]) + (y - c[1]) * (y - c[1]);
        if (d2 >= R * R) return false;
        const double half = std::sqrt(R * R - d2);
        const double zlo = std::max(g.z0, c[2] - half), zhi = c[2] + half;
        if (zhi <= zlo) return false;
        const uint64_t qlo = quantaAt(g, zlo), qhi = quantaAt(g, zhi);
        if (qhi <= qlo) return false;
        // Roots of f_e along the axis, by sampling and linear interpolation.
        const int n = std::max(2, int(std::ceil((zhi - zlo) / step)));
        std::vector<uint64_t> cuts;
        double pz = zlo, pf = fe(Vec3d(x, y, zlo));
        for (int s = 1; s <= n; ++s) {
            const double z = zlo + (zhi - zlo) * s / n, fz = fe(Vec3d(x, y, z));
            if ((fz > 0) != (pf > 0)) cuts.push_back(quantaAt(g, pz + (z - pz) * pf / (pf - fz)));
            pz = z;
            pf = fz;
        }
        const int64_t before = quantaOf(layers, Material::Bedrock), sand0 = quantaOf(layers, Material::Sand),
                      rocks0 = quantaOf(layers, Material::Rocks);
        const std::vector<Layer> old = layers;
        overwrite(layers, qlo, qhi, cuts, [&](Material m, uint64_t a, uint64_t b) {
            const double zm = g.z0 + 0.5 * double(a + b) * g.quantum;
            if (fe(Vec3d(x, y, zm)) > 0) return Material::Bedrock;
            return m == Material::Bedrock ? Material::Air : m;
        });
        st.bedrock += quantaOf(layers, Material::Bedrock) - before;
        st.sand += quantaOf(layers, Material::Sand) - sand0;
        st.rocks += quantaOf(layers, Material::Rocks) - rocks0;
        if (layers == old) return false;
        touched.add(i, j);
        return true;
    });
}

// ---- cracks and tunnels (§4.2) ---------------------------------------------------------------

// The ground's bedrock top under (x, y): the highest bedrock boundary of the four stacks around
// it, bilinearly (a stack's value at its axis).
class BedrockTop
{
public:
    explicit BedrockTop(const Stacks& s) : mStacks(s) {}

    double operator()(double x, double y)
    {
        const auto& g = mStacks.geometry();
        const double fx = (x - g.x0) / g.cell - 0.5, fy = (y - g.y0) / g.cell - 0.5;
        const int i = int(std::floor(fx)), j = int(std::floor(fy));
        const double tx = fx - i, ty = fy - j;
        auto at = [&](int a, int b) { return top(std::clamp(a, 0, g.nx - 1), std::clamp(b, 0, g.ny - 1)); };
        return (at(i, j) * (1 - tx) + at(i + 1, j) * tx) * (1 - ty) + (at(i, j + 1) * (1 - tx) + at(i + 1, j + 1) * tx) * ty;
    }

private:
    double top(int i, int j)
    {
        const size_t key = mStacks.geometry().index(i, j);
        const auto it = mCache.find(key);
        if (it != mCache.end()) return it->second;
        std::vector<Layer> layers;
        mStacks.layers(i, j, layers);
        uint64_t z = 0, t = 0;
        for (const Layer& l : layers) {
            z += l.thickness;
            if (l.material == Material::Bedrock) t = z;
        }
        const double h = mStacks.geometry().z0 + double(t) * mStacks.geometry().quantum;
        mCache.emplace(key, h);
        return h;
    }

    const Stacks& mStacks;
    std::map<size_t, double> mCache;
};

// The bedrock's convolution field round a crack's 3D nodes (§3.3; positive inside), and the
// projection on its surface nearest to a point: Newton steps on the field of a kernel 4σ wide
// (smooth, and not yet saturated 4σ from the surface), then on the field of σ itself.
class BedrockSurface
{
public:
    BedrockSurface(const Stacks& stacks, const std::vector<Vec3d>& nodes, double sigma, double margin, Task& task)
        : mSigma(sigma)
    {
        const auto& g = stacks.geometry();
        Vec3d lo = nodes[0], hi = nodes[0];
        for (const Vec3d& v : nodes) {
            lo = minComponent(lo, v);
            hi = maxComponent(hi, v);
        }
        const double reach = margin + 8 * sigma + 2 * g.cell;
        int i0, j0, i1, j1;
        axisWindow(g, 0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]),
                   reach + 0.5 * std::max(hi[0] - lo[0], hi[1] - lo[1]), i0, j0, i1, j1);
        mWindow = std::make_unique<Stacks>(stacks.window(i0, j0, i1, j1, task));
        mBedrock = std::make_unique<Skeleton>(*mWindow, maskOf(Material::Bedrock));
    }

    double field(const Vec3d& p, double sigma) const { return mBedrock->field(p, sigma); }

    Vec3d gradient(const Vec3d& p, double sigma) const
    {
        const double h = 0.5 * sigma;
        Vec3d d;
        for (int a = 0; a < 3; ++a) {
            Vec3d e(0.0);
            e[a] = h;
            d[a] = (field(p + e, sigma) - field(p - e, sigma)) / (2 * h);
        }
        return d;
    }

    /// The surface point nearest @a q; false when no surface is within ~4σ of it.
    bool project(Vec3d& q) const
    {
        for (const double sigma : {4 * mSigma, mSigma}) {
            for (int it = 0; it < 40; ++it) {
                const double f = field(q, sigma);
                const Vec3d d = gradient(q, sigma);
                const double g2 = d.lengthSqr();
                if (g2 < 1e-12) return false; // saturated: no surface within the kernel
                Vec3d step = d * (-f / g2);
                const double len = step.length();
                if (len > 0.5 * sigma) step *= 0.5 * sigma / len;
                q += step;
                if (len < 1e-4 * sigma) break;
            }
        }
        return std::abs(field(q, mSigma)) < 0.05;
    }

    /// The outward normal at @a p (the field grows inwards).
    Vec3d normal(const Vec3d& p) const
    {
        const Vec3d d = gradient(p, mSigma);
        return d.lengthSqr() > 1e-24 ? -d.unit() : Vec3d(0, 0, 1);
    }

private:
    double mSigma;
    std::unique_ptr<Stacks> mWindow;
    std::unique_ptr<Skeleton> mBedrock;
};

void sweep(Stacks& stacks, const json& e, size_t index, const std::string& tool, const EditContext& ctx,
           Touched& touched, EditStats& st, Task& task)
{
    const auto& g = stacks.geometry();
    const bool crack = tool == "crack";
    SweepSpec spec;
    const json& nodes = e.at("nodes");
    // A crack's nodes are [x, y] (projected down on the ground's bedrock top) or [x, y, z]
    // (projected on the nearest bedrock surface, any orientation: §4.2 projects G "onto the
    // surface of the terrain" — a cliff face or an overhang's underside as well as a top).
    const bool onSurface = !crack || nodes[0].size() == 3;
    for (size_t q = 0; q < nodes.size(); ++q) {
        const auto v = vec(nodes[q], onSurface ? 3 : 2, "nodes", index, tool);
        requireInside(g, v[0], v[1], index, tool, ("nodes[" + std::to_string(q) + "]").c_str());
        spec.nodes.emplace_back(v[0], v[1], onSurface ? v[2] : 0.0);
    }
    if (e.contains("arcs")) {
        for (const auto& a : e.at("arcs")) spec.arcs.emplace_back(a[0].get<int>(), a[1].get<int>());
    } else {
        for (size_t q = 0; q + 1 < nodes.size(); ++q) spec.arcs.emplace_back(int(q), int(q + 1));
    }
    const bool spline = e.at("spline").get<bool>();
    constexpr int kProfilePoints = 48;
    if (e.contains("profiles")) {
        for (const auto& p : e.at("profiles")) spec.profiles.push_back(sampleProfile(profileOf(p, "profiles", index, tool), spline, kProfilePoints));
        for (const auto& k : e.at("node_profiles")) spec.nodeProfile.push_back(k.get<int>());
    } else {
        spec.profiles.push_back(sampleProfile(profileOf(e.at("profile"), "profile", index, tool), spline, kProfilePoints));
        spec.nodeProfile.assign(nodes.size(), 0);
    }
    spec.step = e.contains("step") ? e.at("step").get<double>() : g.cell;
    BedrockTop top(stacks);
    std::unique_ptr<BedrockSurface> surface;
    if (crack && onSurface) {
        double extent = 0; // the profiles' reach from their centre
        for (const auto& prof : spec.profiles)
            for (const Vec2d& u : prof) extent = std::max(extent, u.length());
        surface = std::make_unique<BedrockSurface>(stacks, spec.nodes, ctx.sigma, extent, task);
        for (size_t q = 0; q < spec.nodes.size(); ++q) {
            Vec3d v = spec.nodes[q];
            if (!surface->project(v)) {
                bad(index, tool, "nodes[" + std::to_string(q) + "] has no bedrock surface within 4 sigma (" +
                                     jsonText(nodes[q]) + ")");
            }
        }
        spec.place = [&](const Vec3d& p) {
            Vec3d q = p;
            surface->project(q); // (between projected nodes: a point near the surface)
            return q;
        };
        spec.normal = [&](const Vec3d& p) { return surface->normal(p); };
    } else if (crack) {
        // Project G on the ground: each cross-section's centre on the bedrock top, its v axis
        // the top's normal.
        spec.place = [&](const Vec3d& p) { return Vec3d(p[0], p[1], top(p[0], p[1])); };
        spec.normal = [&](const Vec3d& p) {
            const double h = g.cell;
            const double dx = (top(p[0] + h, p[1]) - top(p[0] - h, p[1])) / (2 * h);
            const double dy = (top(p[0], p[1] + h) - top(p[0], p[1] - h)) / (2 * h);
            return Vec3d(-dx, -dy, 1.0).unitSafe();
        };
    }
    const SweepVolume volume = [&] {
        try {
            return SweepVolume(spec);
        } catch (const ValueError& x) {
            const std::string m = x.what();
            const size_t at = m.find("sweep: ");
            bad(index, tool, at == std::string::npos ? m : m.substr(at + 7)); // the edit's index on it
        }
    }();
    task.check();
    // The stacks under the volume: bedrock inside it becomes air (granular material stays, for
    // the stabilisation to drop into the new room), the rest as it is: the CSG difference
    // min(f, −f*) of §4.2 taken on the layers themselves.
    const BBoxd b = volume.bounds();
    const int i0 = std::max(0, int(std::floor((b.min()[0] - g.x0) / g.cell)));
    const int i1 = std::min(g.nx - 1, int(std::floor((b.max()[0] - g.x0) / g.cell)));
    const int j0 = std::max(0, int(std::floor((b.min()[1] - g.y0) / g.cell)));
    const int j1 = std::min(g.ny - 1, int(std::floor((b.max()[1] - g.y0) / g.cell)));
    const double step = std::max(g.quantum, 0.25 * g.cell);
    size_t visited = 0;
    st.stacks += stacks.edit(i0, j0, i1, j1, [&](int i, int j, std::vector<Layer>& layers) {
        if ((++visited & 63) == 0) task.check(); // a big stroke or sweep stays interruptible
        const double x = g.x0 + (i + 0.5) * g.cell, y = g.y0 + (j + 0.5) * g.cell;
        const std::vector<uint32_t> prisms = volume.candidates(x, y);
        if (prisms.empty()) return false;
        const auto [zlo, zhi] = volume.zRange(prisms);
        const double lo = std::max(g.z0, zlo);
        if (zhi <= lo) return false;
        const int n = std::max(2, int(std::ceil((zhi - lo) / step)));
        std::vector<uint64_t> cuts;
        bool any = false;
        double pz = lo, pf = volume.inside(Vec3d(x, y, lo), prisms);
        any = pf > 0;
        for (int k = 1; k <= n; ++k) {
            const double z = lo + (zhi - lo) * k / n, fz = volume.inside(Vec3d(x, y, z), prisms);
            if ((fz > 0) != (pf > 0)) {
                // The boundary by bisection: inside() bends at a profile's corners (a V's
                // apex), where interpolating it would miss by up to a step.
                double a = pz, c = z;
                const bool inA = pf > 0;
                for (int it = 0; it < 12; ++it) {
                    const double mid = 0.5 * (a + c);
                    if ((volume.inside(Vec3d(x, y, mid), prisms) > 0) == inA) a = mid;
                    else c = mid;
                }
                cuts.push_back(quantaAt(g, 0.5 * (a + c)));
            }
            any = any || fz > 0;
            pz = z;
            pf = fz;
        }
        if (!any) return false;
        const uint64_t qlo = quantaAt(g, lo), qhi = quantaAt(g, zhi);
        const int64_t before = quantaOf(layers, Material::Bedrock);
        overwrite(layers, qlo, qhi, cuts, [&](Material m, uint64_t a, uint64_t c) {
            if (m != Material::Bedrock) return m;
            const double zm = g.z0 + 0.5 * double(a + c) * g.quantum;
            return volume.inside(Vec3d(x, y, zm), prisms) > 0 ? Material::Air : m;
        });
        const int64_t removed = before - quantaOf(layers, Material::Bedrock);
        if (removed == 0) return false;
        st.bedrock -= removed;
        touched.add(i, j);
        return true;
    });
}

// ---- deposit (§4.3) and erode (§4.4) ---------------------------------------------------------

void deposit(Stacks& stacks, const json& e, size_t index, Touched& touched, EditStats& st)
{
    const auto& g = stacks.geometry();
    const auto c = vec(e.at("center"), 2, "center", index, "deposit");
    requireInside(g, c[0], c[1], index, "deposit", "center");
    const double R = number(e, "radius", index, "deposit"), amount = number(e, "amount", index, "deposit");
    const Material m = e.at("material") == "rocks" ? Material::Rocks : Material::Sand;
    const bool smooth = e.at("profile") == "smooth";
    const bool intoRoom = e.contains("z");
    const double zr = intoRoom ? number(e, "z", index, "deposit") : 0.0;
    int i0, j0, i1, j1;
    axisWindow(g, c[0], c[1], R, i0, j0, i1, j1);
    st.stacks += stacks.edit(i0, j0, i1, j1, [&](int i, int j, std::vector<Layer>& layers) {
        const double x = g.x0 + (i + 0.5) * g.cell, y = g.y0 + (j + 0.5) * g.cell;
        const double r2 = ((x - c[0]) * (x - c[0]) + (y - c[1]) * (y - c[1])) / (R * R);
        if (r2 >= 1.0) return false;
        const double h = amount * (smooth ? (1.0 - r2) * (1.0 - r2) : 1.0);
        const uint64_t t = uint64_t(std::llround(h / g.quantum));
        if (t == 0) return false;
        if (!intoRoom) {
            layers.push_back(Layer{m, uint32_t(std::min<uint64_t>(t, 0xffffffffu))});
        } else {
            // Into the room holding zr: inserted at zr (stabilisation then lays it on the room's
            // floor); a zr inside bedrock catches nothing.
            const uint64_t q = quantaAt(g, zr);
            uint64_t z = 0;
            size_t at = layers.size();
            for (size_t l = 0; l < layers.size(); ++l) {
                if (q >= z && q < z + layers[l].thickness) {
                    if (layers[l].material == Material::Bedrock) return false; // inside rock: nothing lands
                    at = l;
                    break;
                }
                z += layers[l].thickness;
            }
            if (at == layers.size()) {
                layers.push_back(Layer{m, uint32_t(t)});
            } else {
                // Split the layer at zr and drop the material there; stabilisation sorts the room.
                const Layer l = layers[at];
                const uint32_t below = uint32_t(q - z);
                std::vector<Layer> mid = {Layer{l.material, below}, Layer{m, uint32_t(t)},
                                          Layer{l.material, l.thickness - below}};
                layers.erase(layers.begin() + std::ptrdiff_t(at));
                layers.insert(layers.begin() + std::ptrdiff_t(at), mid.begin(), mid.end());
            }
        }
        (m == Material::Sand ? st.sand : st.rocks) += int64_t(t);
        touched.add(i, j);
        return true;
    });
}

// Intervals [a, b) sorted and merged where they touch or overlap.
std::vector<std::pair<uint64_t, uint64_t>> mergeIntervals(std::vector<std::pair<uint64_t, uint64_t>> in)
{
    std::sort(in.begin(), in.end());
    std::vector<std::pair<uint64_t, uint64_t>> out;
    for (const auto& r : in) {
        if (!out.empty() && r.first <= out.back().second) out.back().second = std::max(out.back().second, r.second);
        else out.push_back(r);
    }
    return out;
}

// The heights where the vertical line through (x, y) lies within R of the segment [a, b] (a
// capsule; a == b: a sphere): one interval, as the capsule is convex. Its ends are the least
// z_c(t) − h(t) and the greatest z_c(t) + h(t) over the centres c(t) = a + t (b − a) within R
// of the line in xy, h(t) = √(R² − d_xy(t)²) concave, so each end is one ternary search.
bool capsuleSpan(const Vec3d& a, const Vec3d& b, double R, double x, double y, double& lo, double& hi)
{
    const Vec3d d = b - a;
    // d_xy(t)² = A t² + B t + C
    const double ex = a[0] - x, ey = a[1] - y;
    const double A = d[0] * d[0] + d[1] * d[1], B = 2 * (ex * d[0] + ey * d[1]), C = ex * ex + ey * ey;
    // The t in [0, 1] with d_xy(t) < R: an interval round the nearest t.
    double t0 = 0, t1 = 1;
    if (A > 1e-18) {
        const double disc = B * B - 4 * A * (C - R * R);
        if (disc <= 0) return false;
        const double sq = std::sqrt(disc);
        t0 = std::max(0.0, (-B - sq) / (2 * A));
        t1 = std::min(1.0, (-B + sq) / (2 * A));
        if (t0 >= t1) return false;
    } else if (C >= R * R) {
        return false;
    }
    auto half = [&](double t) { return std::sqrt(std::max(0.0, R * R - (A * t * t + B * t + C))); };
    auto extreme = [&](double sign) { // sign −1: min of z − h; +1: max of z + h
        double u = t0, v = t1;
        for (int k = 0; k < 100 && v - u > 1e-12; ++k) {
            const double m1 = u + (v - u) / 3, m2 = v - (v - u) / 3;
            const double f1 = sign * (a[2] + m1 * d[2]) + half(m1), f2 = sign * (a[2] + m2 * d[2]) + half(m2);
            if (f1 < f2) u = m1;
            else v = m2;
        }
        const double t = 0.5 * (u + v);
        return a[2] + t * d[2] + sign * half(t);
    };
    lo = extreme(-1.0);
    hi = extreme(1.0);
    return hi > lo;
}

void erode(Stacks& stacks, const json& e, size_t index, Touched& touched, EditStats& st)
{
    const auto& g = stacks.geometry();
    // The region: the sphere at center, or swept along the stroke's segments (§4.4: "erosion
    // is performed by sweeping the erosion tool over the surface").
    std::vector<Vec3d> stroke;
    if (e.contains("center")) {
        const auto c = vec(e.at("center"), 3, "center", index, "erode");
        requireInside(g, c[0], c[1], index, "erode", "center");
        stroke.emplace_back(c[0], c[1], c[2]);
    } else {
        const json& points = e.at("points");
        for (size_t q = 0; q < points.size(); ++q) {
            const auto v = vec(points[q], 3, "points", index, "erode");
            requireInside(g, v[0], v[1], index, "erode", ("points[" + std::to_string(q) + "]").c_str());
            stroke.emplace_back(v[0], v[1], v[2]);
        }
    }
    const double R = number(e, "radius", index, "erode");
    const bool collapse = e.at("mode") == "collapse";
    const double rho = number(e, "rho", index, "erode");
    const double depth = e.contains("depth") ? number(e, "depth", index, "erode") : g.cell;
    const uint64_t dq = std::max<uint64_t>(1, uint64_t(std::llround(depth / g.quantum)));
    Vec3d bmin = stroke[0], bmax = stroke[0];
    for (const Vec3d& v : stroke) {
        bmin = minComponent(bmin, v);
        bmax = maxComponent(bmax, v);
    }
    int i0, j0, i1, j1;
    axisWindow(g, 0.5 * (bmin[0] + bmax[0]), 0.5 * (bmin[1] + bmax[1]),
               R + 0.5 * std::max(bmax[0] - bmin[0], bmax[1] - bmin[1]), i0, j0, i1, j1);
    st.stacks += stacks.edit(i0, j0, i1, j1, [&](int i, int j, std::vector<Layer>& layers) {
        const double x = g.x0 + (i + 0.5) * g.cell, y = g.y0 + (j + 0.5) * g.cell;
        // The region on this stack's axis: the union of the segments' spans, in quanta.
        std::vector<std::pair<uint64_t, uint64_t>> region;
        for (size_t q = 0; q < std::max<size_t>(1, stroke.size() - 1); ++q) {
            double zlo, zhi;
            const Vec3d& a = stroke[q];
            const Vec3d& b = stroke[std::min(q + 1, stroke.size() - 1)];
            if (!capsuleSpan(a, b, R, x, y, zlo, zhi)) continue;
            const uint64_t qa = quantaAt(g, zlo), qb = quantaAt(g, zhi);
            if (qa < qb) region.emplace_back(qa, qb);
        }
        if (region.empty()) return false;
        const std::vector<std::pair<uint64_t, uint64_t>> spans = mergeIntervals(std::move(region));
        const uint64_t lo = spans.front().first, hi = spans.back().second;
        // The bedrock within the sphere (collapse), or within depth of an exposed face (surface).
        std::vector<std::pair<uint64_t, uint64_t>> eroded; // [a, b) quanta
        uint64_t z = 0;
        for (size_t l = 0; l < layers.size(); ++l) {
            const uint64_t a = z, b = z + layers[l].thickness;
            z = b;
            if (layers[l].material != Material::Bedrock) continue;
            if (collapse) {
                eroded.emplace_back(a, b);
                continue;
            }
            const bool openAbove = l + 1 == layers.size() || layers[l + 1].material != Material::Bedrock;
            const bool openBelow = l > 0 && layers[l - 1].material != Material::Bedrock;
            if (openAbove) eroded.emplace_back(b > dq ? std::max(a, b - dq) : a, b);
            if (openBelow) eroded.emplace_back(a, std::min(b, a + dq));
        }
        // Clip to the region, sort and merge (a thin layer's top and underside skins overlap).
        std::vector<std::pair<uint64_t, uint64_t>> merged;
        for (const auto& [ea, eb] : eroded) {
            for (const auto& [ra, rb] : spans) {
                const uint64_t a = std::max(ea, ra), b = std::min(eb, rb);
                if (a < b) merged.emplace_back(a, b);
            }
        }
        if (merged.empty()) return false;
        const std::vector<std::pair<uint64_t, uint64_t>> parts = mergeIntervals(std::move(merged));
        uint64_t total = 0;
        for (const auto& [a, b] : parts) total += b - a;
        // Eroded bedrock becomes sand, and in collapse mode its top share rho becomes rocks
        // (the fragments above, the fines below; stabilisation sorts the room anyway): whole
        // quanta per stack, so bedrock lost = granular gained exactly.
        const uint64_t rocks = collapse ? uint64_t(std::llround(rho * double(total))) : 0;
        std::vector<uint64_t> cuts;
        std::vector<std::pair<uint64_t, uint64_t>> rockParts;
        uint64_t left = rocks;
        for (size_t k = parts.size(); k-- > 0 && left > 0;) {
            const uint64_t take = std::min(left, parts[k].second - parts[k].first);
            rockParts.emplace_back(parts[k].second - take, parts[k].second);
            left -= take;
        }
        for (const auto& [a, b] : parts) {
            cuts.push_back(a);
            cuts.push_back(b);
        }
        for (const auto& [a, b] : rockParts) cuts.push_back(a);
        auto within = [](const std::vector<std::pair<uint64_t, uint64_t>>& list, uint64_t a, uint64_t b) {
            for (const auto& [x0, x1] : list) {
                if (a >= x0 && b <= x1) return true;
            }
            return false;
        };
        overwrite(layers, lo, hi, cuts, [&](Material m, uint64_t a, uint64_t b) {
            if (m != Material::Bedrock || !within(parts, a, b)) return m;
            return within(rockParts, a, b) ? Material::Rocks : Material::Sand;
        });
        st.bedrock -= int64_t(total);
        st.sand += int64_t(total - rocks);
        st.rocks += int64_t(rocks);
        touched.add(i, j);
        return true;
    });
}

} // namespace

const json& editTools()
{
    static const json t = [] {
        json out = json::object();
        for (const auto& [name, tool] : tools()) {
            json keys = json::array();
            for (const Key& k : tool.keys) {
                const bool ranged = std::isfinite(k.range.min) || std::isfinite(k.range.max);
                keys.push_back({{"name", k.name}, {"type", k.type}, {"default", k.def}, {"help", k.help},
                                {"required", k.required}, {"range", ranged ? json(k.range.text()) : json()},
                                {"choices", k.choices}});
            }
            out[name] = {{"help", tool.help}, {"keys", keys}};
        }
        return out;
    }();
    return t;
}

json withDefaults(const json& e)
{
    json out = e;
    for (const Key& k : tools().at(e.at("tool").get<std::string>()).keys) {
        if (!out.contains(k.name) && !k.def.is_null()) out[k.name] = k.def;
    }
    return out;
}

void validateEdit(const json& e, size_t index)
{
    if (!e.is_object()) fail<ValueError>("arches: edits[", index, "] must be an object {\"tool\": ..., ...}");
    if (!e.contains("tool") || !e.at("tool").is_string()) {
        fail<ValueError>("arches: edits[", index, "] needs \"tool\": sculpt, crack, tunnel, deposit, erode or stabilize");
    }
    const std::string tool = e.at("tool").get<std::string>();
    if (!tools().count(tool)) {
        fail<ValueError>("arches: edits[", index, "]: unknown tool '", tool, "' (sculpt, crack, tunnel, deposit, erode, stabilize)");
    }
    const std::vector<Key>& keys = tools().at(tool).keys;
    std::vector<std::string> names = {"tool"};
    for (const Key& k : keys) names.push_back(k.name);
    for (auto it = e.begin(); it != e.end(); ++it) {
        if (std::find(names.begin(), names.end(), it.key()) == names.end()) {
            const std::string close = closestName(it.key(), names);
            bad(index, tool, "'" + it.key() + "' is not a key of " + tool + (close.empty() ? "" : " (did you mean '" + close + "'?)"));
        }
    }
    for (const Key& k : keys) {
        const std::string& name = k.name;
        if (k.required && !e.contains(name)) {
            bad(index, tool, name + " is required");
        }
        if (!e.contains(name)) continue;
        const std::string& type = k.type;
        if (type == "number" && !k.range.contains(number(e, name.c_str(), index, tool))) {
            bad(index, tool, name + " must be " + k.range.text() + " (got " + jsonText(e.at(name)) + ")");
        }
        if (type == "string" && !e.at(name).is_string()) bad(index, tool, name + " must be a string");
        if (!k.choices.empty() &&
            std::find(k.choices.begin(), k.choices.end(), e.at(name).get<std::string>()) == k.choices.end()) {
            std::string list;
            for (const auto& c : k.choices) list += (list.empty() ? "" : ", ") + c;
            bad(index, tool, name + " must be one of " + list + " (got '" + e.at(name).get<std::string>() + "')");
        }
        if (type == "xy") vec(e.at(name), 2, name, index, tool);
        if (type == "xyz") vec(e.at(name), 3, name, index, tool);
        if (type == "points" || type == "points2" || type == "points23") {
            const json& p = e.at(name);
            // points23: [x, y] or [x, y, z], as the first node is.
            const size_t dim = type == "points" ? 3 : type == "points2" ? 2
                             : (p.is_array() && !p.empty() && p[0].is_array() && p[0].size() == 3 ? 3 : 2);
            if (!p.is_array() || p.empty()) {
                bad(index, tool, name + " must be a non-empty list of " +
                                     (type == "points23" ? "[x, y] or of [x, y, z]" : dim == 3 ? "[x, y, z]" : "[x, y]"));
            }
            for (size_t q = 0; q < p.size(); ++q) vec(p[q], dim, name + "[" + std::to_string(q) + "]", index, tool);
        }
        if (type == "bool" && !e.at(name).is_boolean()) bad(index, tool, name + " must be true or false");
        if (type == "arcs" || type == "ints") {
            const json& a = e.at(name);
            if (!a.is_array()) bad(index, tool, name + " must be a list");
            for (size_t q = 0; q < a.size(); ++q) {
                const json& x = a[q];
                const bool ok = type == "ints" ? x.is_number_integer()
                                               : x.is_array() && x.size() == 2 && x[0].is_number_integer() &&
                                                     x[1].is_number_integer();
                if (!ok) bad(index, tool, name + "[" + std::to_string(q) + "] must be " + (type == "ints" ? "an integer" : "[a, b], two node indices"));
            }
        }
        if (type == "profile") profileOf(e.at(name), name, index, tool);
        if (type == "profiles") {
            const json& ps = e.at(name);
            if (!ps.is_array() || ps.empty()) bad(index, tool, name + " must be a non-empty list of profiles");
            for (size_t q = 0; q < ps.size(); ++q) profileOf(ps[q], name + "[" + std::to_string(q) + "]", index, tool);
        }
    }
    // The rules between keys (each key's own type, range and choices are checked above).
    const json full = withDefaults(e);
    if (tool == "sculpt") {
        if (e.contains("depth")) {
            const double d = e.at("depth").get<double>(), R = e.at("radius").get<double>();
            if (!(d <= R)) bad(index, tool, "depth must be in [0, radius] (got " + jsonText(e.at("depth")) + ")");
            if (full.at("at") == "center") bad(index, tool, "depth applies to at = surface");
        }
    } else if (tool == "crack" || tool == "tunnel") {
        const size_t nodes = e.at("nodes").size();
        if (nodes < 2) bad(index, tool, "nodes needs at least 2 nodes");
        if (!e.contains("profile") && !e.contains("profiles")) bad(index, tool, "profile (or profiles) is required");
        if (e.contains("profile") && e.contains("profiles")) bad(index, tool, "give profile or profiles, not both");
        std::vector<int> degree(nodes, 0);
        if (e.contains("arcs")) {
            const json& arcs = e.at("arcs");
            if (arcs.empty()) bad(index, tool, "arcs must hold at least one arc");
            for (size_t q = 0; q < arcs.size(); ++q) {
                const int a = arcs[q][0].get<int>(), b = arcs[q][1].get<int>();
                if (a < 0 || b < 0 || size_t(a) >= nodes || size_t(b) >= nodes) {
                    bad(index, tool, "arcs[" + std::to_string(q) + "] names a node that does not exist (" +
                                         std::to_string(nodes) + " nodes)");
                }
                if (a == b) bad(index, tool, "arcs[" + std::to_string(q) + "] joins a node to itself");
                ++degree[size_t(a)];
                ++degree[size_t(b)];
            }
            for (size_t q = 0; q < nodes; ++q) {
                if (degree[q] == 0) bad(index, tool, "nodes[" + std::to_string(q) + "] is on no arc (a dangling node)");
            }
        }
        if (e.contains("profiles")) {
            if (!e.contains("node_profiles")) bad(index, tool, "profiles needs node_profiles (one profile index per node)");
            const json& np = e.at("node_profiles");
            if (np.size() != nodes) bad(index, tool, "node_profiles needs one index per node (" + std::to_string(nodes) + ")");
            for (size_t q = 0; q < np.size(); ++q) {
                const int k = np[q].get<int>();
                if (k < 0 || size_t(k) >= e.at("profiles").size()) {
                    bad(index, tool, "node_profiles[" + std::to_string(q) + "] names no profile");
                }
            }
        } else if (e.contains("node_profiles")) {
            bad(index, tool, "node_profiles applies to profiles");
        }
    } else if (tool == "erode") {
        if (e.contains("center") == e.contains("points")) bad(index, tool, "give center or points (a stroke), one of them");
        const bool collapse = full.at("mode") == "collapse";
        if (e.contains("rho") && !collapse) bad(index, tool, "rho applies to mode collapse");
        if (e.contains("depth") && collapse) bad(index, tool, "depth applies to mode surface");
    }
}

EditStats applyEdit(Stacks& stacks, const json& given, size_t index, const EditContext& ctx, Task& task)
{
    validateEdit(given, index);
    const json e = withDefaults(given); // every key with a default holds it from here on
    const auto t0 = std::chrono::steady_clock::now();
    EditStats st;
    st.tool = e.at("tool").get<std::string>();
    Stacks work = stacks; // the caller's stacks change only when the edit succeeds
    const auto& g = work.geometry();
    if (st.tool == "stabilize") {
        work = stabilizeStacks(work, ctx.angles, task, &st.stabilize);
    } else {
        Touched touched;
        if (st.tool == "sculpt") {
            const double R = e.at("radius").get<double>();
            const bool add = e.at("mode") == "add";
            const double delta = e.contains("depth") ? e.at("depth").get<double>() : 0.5 * R;
            const double k = e.at("strength").get<double>();
            const bool atCenter = e.at("at") == "center";
            const json& points = e.at("points");
            for (size_t q = 0; q < points.size(); ++q) {
                const auto v = vec(points[q], 3, "points", index, "sculpt");
                requireInside(g, v[0], v[1], index, "sculpt", ("points[" + std::to_string(q) + "]").c_str());
                sculptPoint(work, v, R, add, delta, k, atCenter, ctx, index, touched, st, task);
            }
        } else if (st.tool == "crack" || st.tool == "tunnel") {
            sweep(work, e, index, st.tool, ctx, touched, st, task);
        } else if (st.tool == "deposit") {
            deposit(work, e, index, touched, st);
        } else {
            erode(work, e, index, touched, st);
        }
        if (touched.any()) {
            st.i0 = touched.i0;
            st.j0 = touched.j0;
            st.i1 = touched.i1;
            st.j1 = touched.j1;
            st.stabilize = stabilizeLocal(work, ctx.angles, st.i0, st.j0, st.i1, st.j1, task);
        }
    }
    stacks = std::move(work);
    st.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return st;
}

} // namespace arches
} // namespace rockvdb
