// SPDX-License-Identifier: Apache-2.0
#include "Preview.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/Triplanar.h>
#include <rockvdb/core/VdbIO.h>

#include <openvdb/math/Ray.h>
#include <openvdb/tools/RayIntersector.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

namespace rockvdb {

const Schema<PreviewSettings>& previewSchema()
{
    static const Schema<PreviewSettings> s = [] {
        using P = PreviewSettings;
        Schema<P> t("preview",
            "Render a shaded PNG of a level set with OpenVDB's LevelSetRayIntersector; the "
            "camera frames the active bounding box from azimuth / elevation.");
        t.member(param("width", ParamType::Int, "pixels", 960, Range::closed(8, 16384),
                       "Image width"), &P::width);
        t.member(param("height", ParamType::Int, "pixels", 540, Range::closed(8, 16384),
                       "Image height"), &P::height);
        t.member(param("azimuth", ParamType::Real, "degrees", 35.0, Range::closed(-1e6, 1e6),
                       "Camera direction around z from +x"), &P::azimuth);
        t.member(param("elevation", ParamType::Real, "degrees", 30.0, Range::closed(-89, 89),
                       "Camera angle above the ground"), &P::elevation);
        t.member(param("fov", ParamType::Real, "degrees", 35.0, Range::open(1, 170),
                       "Vertical field of view"), &P::fov);
        t.member(param("zoom", ParamType::Real, "", 1.0, Range::openClosed(0, 1e6),
                       "> 1 moves the camera closer"), &P::zoom);
        t.member(param("texture", ParamType::Bool, "", false, Range::any(),
                       "Texture the surface by its material weight grids (weight_sand, weight_bedrock, "
                       "weight_rocks: vdb_arches' §6 output): each material's pattern mapped triplanarly "
                       "with Lp weights, p = 8, blended by the weights at each pixel"), &P::texture);
        return t;
    }();
    return s;
}

PreviewSettings::PreviewSettings() { previewSchema().reset(*this); }

void PreviewSettings::validate() const { previewSchema().validate(*this); }

std::map<int, std::array<double, 3>> parsePalette(const std::string& text, const std::string& what)
{
    std::map<int, std::array<double, 3>> out;
    size_t start = 0;
    while (start <= text.size()) {
        const size_t end = std::min(text.find(',', start), text.size());
        const std::string item = text.substr(start, end - start);
        const size_t eq = item.find('=');
        char* stop = nullptr;
        const long id = eq == std::string::npos ? -1 : std::strtol(item.c_str(), &stop, 10);
        const std::string hex = eq == std::string::npos ? "" : item.substr(eq + 1);
        const bool hexOk = hex.size() == 7 && hex[0] == '#' &&
            std::all_of(hex.begin() + 1, hex.end(), [](char c) { return std::isxdigit(uint8_t(c)); });
        if (eq == std::string::npos || stop != item.c_str() + eq || id < 0 || id >= (1 << 24) ||
            !hexOk) {
            fail<ValueError>(what, ": expected ID=#rrggbb entries separated by commas (got '",
                             item, "')");
        }
        std::array<double, 3> rgb;
        for (int k = 0; k < 3; ++k) {
            const double v = std::stoi(hex.substr(1 + 2 * size_t(k), 2), nullptr, 16) / 255.0;
            rgb[size_t(k)] = std::pow(v, 1.8); // the display gamma renderPreview applies
        }
        out[int(id)] = rgb;
        start = end + 1;
    }
    return out;
}

std::array<double, 3> materialColour(const std::string& name)
{
    if (name == "sand") return {{0.62, 0.50, 0.30}};
    if (name == "bedrock") return {{0.42, 0.40, 0.38}};
    if (name == "rocks") return {{0.30, 0.29, 0.28}};
    uint64_t h = 0;
    for (char c : name) h = random::mix64(h + uint8_t(c));
    return {{0.3 + 0.4 * random::toUnit(h), 0.3 + 0.4 * random::toUnit(random::mix64(h)),
             0.3 + 0.4 * random::toUnit(random::mix64(h + 1))}};
}

std::vector<PreviewMaterial> previewMaterials(const openvdb::GridPtrVec& grids)
{
    std::vector<PreviewMaterial> out;
    for (const auto& g : grids) {
        const std::string name = g ? g->getName() : std::string();
        if (name.rfind("weight_", 0) != 0 || name.size() == 7) continue;
        auto f = openvdb::gridConstPtrCast<openvdb::FloatGrid>(g);
        if (!f) continue;
        PreviewMaterial m;
        m.name = name.substr(7);
        m.weight = f;
        m.colour = materialColour(m.name);
        out.push_back(m);
    }
    return out;
}

std::array<double, 3> materialTexture(const PreviewMaterial& m, const openvdb::Vec3d& p, const openvdb::Vec3d& n)
{
    // Each material's 2D pattern T(u, v) (a shade around 1): sand a fine grain; bedrock strata
    // along the second coordinate (horizontal bands on walls, where it is z) broken by noise;
    // rocks blotches; others a soft noise.
    const uint64_t seed = m.name == "sand" ? 1 : m.name == "bedrock" ? 2 : m.name == "rocks" ? 3 : 4;
    auto T = [&](double u, double v, bool vIsZ) {
        if (m.name == "sand") return 0.9 + 0.2 * noise::gradient2(seed, float(u * 9), float(v * 9));
        if (m.name == "bedrock") {
            const double wobble = noise::gradient2(seed, float(u * 0.7), float(v * 0.7));
            if (!vIsZ) return 0.93 + 0.12 * wobble;
            return 0.9 + 0.1 * std::sin(2 * M_PI * (v / 0.45 + 0.6 * wobble)) + 0.05 * wobble;
        }
        if (m.name == "rocks") return 0.75 + 0.5 * std::abs(noise::gradient2(seed, float(u * 2.5), float(v * 2.5)));
        return 0.9 + 0.15 * noise::gradient2(seed, float(u * 3), float(v * 3));
    };
    const double shade = triplanar(float(n[0]), float(n[1]), float(n[2]), float(T(p[0], p[1], false)),
                                   float(T(p[0], p[2], true)), float(T(p[1], p[2], true)), 8.0f);
    return {{m.colour[0] * shade, m.colour[1] * shade, m.colour[2] * shade}};
}

std::vector<uint8_t> renderPreview(const openvdb::FloatGrid& grid, const PreviewSettings& s,
                                   const openvdb::FloatGrid* ids, PreviewStats* stats,
                                   const std::vector<PreviewMaterial>* materials)
{
    if (s.texture && (!materials || materials->empty())) {
        fail<ValueError>("preview: texture needs material weight grids (weight_sand, ...: vdb_arches writes them "
                         "unless --no-weights)");
    }
    const std::vector<PreviewMaterial> none;
    const std::vector<PreviewMaterial>& mats = s.texture ? *materials : none;
    std::vector<int32_t> dominant(s.texture ? size_t(s.width) * size_t(s.height) : 0, -1);
    s.validate();
    requireLevelSet(grid, "preview input");
    using Vec3R = openvdb::Vec3R;
    std::vector<uint8_t> rgb(size_t(s.width) * size_t(s.height) * 3);
    // What each pixel shows: kSky, kSurface (no id) or the id.
    constexpr int32_t kSky = -2, kSurface = -1;
    std::vector<int32_t> shown(size_t(s.width) * size_t(s.height), kSky);
    const openvdb::CoordBBox ibox = grid.evalActiveVoxelBoundingBox();
    auto sky = [&](double t) {
        // Vertical gradient background.
        return Vec3R(0.80 - 0.25 * t, 0.84 - 0.22 * t, 0.90 - 0.15 * t);
    };
    if (grid.activeVoxelCount() == 0 || ibox.empty()) {
        for (int j = 0; j < s.height; ++j)
            for (int i = 0; i < s.width; ++i) {
                const Vec3R c = sky(double(j) / s.height);
                for (int k = 0; k < 3; ++k) rgb[(size_t(j) * s.width + i) * 3 + k] = uint8_t(c[k] * 255);
            }
        return rgb;
    }
    const openvdb::BBoxd wbox = grid.transform().indexToWorld(ibox);
    const Vec3R center = wbox.getCenter();
    const double radius = 0.5 * (wbox.max() - wbox.min()).length();
    const double az = s.azimuth * M_PI / 180, el = s.elevation * M_PI / 180;
    const Vec3R toEye(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    const double halfFov = 0.5 * s.fov * M_PI / 180;
    const double aspect = double(s.width) / s.height;
    const double fit = std::min(std::tan(halfFov), std::tan(halfFov) * aspect);
    const double dist = radius / std::sin(std::atan(fit)) * 1.02 / s.zoom;
    const Vec3R eye = center + toEye * dist;
    const Vec3R fwd = -toEye;
    Vec3R right = fwd.cross(Vec3R(0, 0, 1));
    if (right.length() < 1e-9) right = Vec3R(1, 0, 0);
    right.normalize();
    const Vec3R up = right.cross(fwd);
    const Vec3R key = (toEye * 0.6 + right * -0.5 + Vec3R(0, 0, 0.9)).unit();

    using Intersector = openvdb::tools::LevelSetRayIntersector<openvdb::FloatGrid>;
    const Intersector proto(grid);
    tbb::parallel_for(tbb::blocked_range<int>(0, s.height), [&](const tbb::blocked_range<int>& r) {
        Intersector inter(proto);
        auto idAcc = ids ? std::make_unique<openvdb::FloatGrid::ConstAccessor>(ids->getConstAccessor())
                         : nullptr;
        std::vector<openvdb::FloatGrid::ConstAccessor> weightAcc;
        for (const auto& m : mats) weightAcc.push_back(m.weight->getConstAccessor());
        const double th = std::tan(halfFov);
        for (int j = r.begin(); j != r.end(); ++j) {
            for (int i = 0; i < s.width; ++i) {
                const double u = ((i + 0.5) / s.width * 2 - 1) * th * aspect;
                const double v = (1 - (j + 0.5) / s.height * 2) * th;
                const Vec3R dir = (fwd + right * u + up * v).unit();
                openvdb::math::Ray<double> ray(eye, dir);
                Vec3R hit, normal;
                Vec3R c = sky(double(j) / s.height);
                if (inter.intersectsWS(ray, hit, normal)) {
                    const Vec3R n = normal.lengthSqr() > 0 ? normal.unit() : -dir;
                    Vec3R albedo(0.62, 0.58, 0.53);
                    int32_t what = kSurface;
                    if (idAcc) {
                        const auto ijk = ids->transform().worldToIndexCellCentered(hit);
                        const float id = idAcc->getValue(ijk);
                        if (id >= 0) {
                            what = int32_t(id);
                            const auto known = s.palette.find(what);
                            if (known != s.palette.end()) {
                                albedo = Vec3R(known->second[0], known->second[1], known->second[2]);
                            } else {
                                const uint64_t h = random::hash(0, 7, uint64_t(int64_t(id)));
                                albedo = Vec3R(0.35 + 0.5 * random::toUnit(h),
                                               0.35 + 0.5 * random::toUnit(random::mix64(h)),
                                               0.35 + 0.5 * random::toUnit(random::mix64(h + 1)));
                            }
                        }
                    }
                    if (!mats.empty()) {
                        // §6: Σ w_m T_m / Σ w_m with the weights at the hit point's voxel.
                        Vec3R sum(0.0);
                        double total = 0, best = 0;
                        for (size_t k = 0; k < mats.size(); ++k) {
                            const auto ijk = mats[k].weight->transform().worldToIndexCellCentered(hit);
                            const double w = std::max(0.0f, weightAcc[k].getValue(ijk));
                            if (w <= 0) continue;
                            const auto t = materialTexture(mats[k], hit, n);
                            sum += Vec3R(t[0], t[1], t[2]) * w;
                            total += w;
                            if (w > best) {
                                best = w;
                                dominant[size_t(j) * size_t(s.width) + size_t(i)] = int32_t(k);
                            }
                        }
                        if (total > 0) albedo = sum / total;
                    }
                    shown[size_t(j) * size_t(s.width) + size_t(i)] = what;
                    const double diffuse = std::max(0.0, n.dot(key));
                    const double skyFill = 0.5 + 0.5 * n[2];
                    const double rim = std::pow(1 - std::max(0.0, n.dot(-dir)), 3) * 0.15;
                    const double l = 0.78 * diffuse + 0.32 * skyFill + rim;
                    c = Vec3R(albedo[0] * l, albedo[1] * l, albedo[2] * l);
                }
                uint8_t* px = &rgb[(size_t(j) * size_t(s.width) + size_t(i)) * 3];
                for (int k = 0; k < 3; ++k) {
                    // sRGB-ish gamma for display.
                    px[k] = uint8_t(std::lround(255 * std::pow(std::clamp(c[k], 0.0, 1.0), 1 / 1.8)));
                }
            }
        }
    });
    if (stats) {
        *stats = PreviewStats();
        stats->pixels = shown.size();
        for (const int32_t w : shown) {
            if (w == kSky) continue;
            ++stats->surfacePixels;
            if (w >= 0) ++stats->idPixels[w];
        }
        for (const int32_t k : dominant) {
            if (k >= 0) ++stats->materialPixels[mats[size_t(k)].name];
        }
    }
    return rgb;
}

void writePreview(const openvdb::FloatGrid& grid, const std::string& path,
                  const PreviewSettings& s, const openvdb::FloatGrid* ids, PreviewStats* stats,
                  const std::vector<PreviewMaterial>* materials)
{
    const auto rgb = renderPreview(grid, s, ids, stats, materials);
    writeFileAtomic(path, encodePngRgb8(s.width, s.height, rgb));
}

} // namespace rockvdb
