// SPDX-License-Identifier: Apache-2.0
#include "DetailStage.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/VdbIO.h>

#include <algorithm>
#include <cstdio>

namespace rockvdb {
namespace detail {

using nlohmann::json;

namespace {

Schema<DetailStageParams> makeSchema()
{
    using P = DetailStageParams;
    Schema<P> s("detail",
        "Add small-scale rock detail to a level set and re-bake it (renormalised). Gradient "
        "warp (implicit blocks §4.2): the surface moves along its normal by a relief seen "
        "through three axis projections blended by |g.u_i|^p. Gabor details (Gabor surface "
        "noise in local frames (n, t, b), b = n ^ W): each point near the surface is projected "
        "on it and the field raised or lowered by D(noise)·(1 - |p p_S|/R)^6. Amplitudes are "
        "in metres and bound the displacement; 0 disables an operator.");
    // A 2 cm warp by default, so that detail at its defaults shows (issue 55: 0 changed
    // nothing): visible on a 1 m rock, a texture on a 20 m cliff; 0 turns it off.
    const auto warp = warpRows(0.02, 8.0,
        "Warp: exponent p of the projection weights |g.u_i|^p (8: the arches paper's texture "
        "blend keeps one projection sharp; 1: the blocks paper's)");
    s.member(warp[0], &P::warpAmplitude);
    s.member(warp[1], &P::warpRelief);
    s.member(warp[2], &P::warpScale);
    s.member(warp[3], &P::warpOctaves);
    s.member(warp[4], &P::warpSharpness);
    s.member(param("gabor-amplitude", ParamType::Real, "m", 0.0, Range::closed(0, 1e3),
                 "Gabor: largest displacement; 0 = off"), &P::gaborAmplitude);
    s.member(param("gabor-frequency", ParamType::Real, "cycles/m", 0.0, Range::atLeast(0),
                 "Gabor: F0, below the voxel Nyquist limit; 0 = 1/(10 x amplitude), ridges ten "
                 "times as wide as they are high"), &P::gaborFrequency);
    s.member(param("gabor-bandwidth", ParamType::Real, "1/m", 0.0, Range::atLeast(0),
                 "Gabor: a; 0 = F0/2"), &P::gaborBandwidth);
    s.member(param("gabor-orientation", ParamType::Real, "degrees", 0.0, Range::closed(-360, 360),
                 "Gabor: frequency direction in the frame, from t towards b"),
             &P::gaborOrientation);
    s.member(param("gabor-impulses", ParamType::Real, "", 16.0, Range::closed(1, 256),
                 "Gabor: impulses per kernel"), &P::gaborImpulses);
    s.member(param("gabor-falloff", ParamType::Real, "m", 0.0, Range::atLeast(0),
                 "Gabor: R of K(r) = (1 - r/R)^6; 0 = 12 x amplitude, the smallest R that keeps "
                 "the field monotone along normals"), &P::gaborFalloff);
    s.member(param("gabor-isotropic", ParamType::Bool, "", false, Range::any(),
                 "Gabor: isotropic noise (no frames)"), &P::gaborIsotropic);
    s.member(param("tilt", ParamType::Reals, "degrees", json::array({0.0, 0.0}),
                 Range::closed(-360, 360),
                 "Gabor: projection tilt alpha (from the normal, 0..75), theta (azimuth from t "
                 "towards b)", 2), &P::tilt);
    s.member(param("direction-axis", ParamType::Reals, "", nullptr, Range::closed(-1e6, 1e6),
                 "W = this axis (default 0,0,1 when no direction is given)", 3),
             &P::directionAxis);
    s.add(param("direction-skeleton", ParamType::Json, "", nullptr, Range::any(),
                 "W = weighted skeleton direction (gabor §3): a JSON file (or object) of "
                 "primitives with a radius of influence each, {\"segments\": [{\"a\", \"b\", "
                 "\"radius\"}], \"polylines\": [{\"points\": [[x,y,z], ...], \"closed\", \"radius\"}], "
                 "\"points\": [{\"p\", \"radius\", \"direction\"}], \"triangles\": [{\"a\", \"b\", \"c\", "
                 "\"radius\", \"direction\"}]}; any primitive may carry \"amplitude\", \"frequency\", "
                 "\"tilt\" (one value or one per vertex), interpolated along the skeleton"),
          [](const P& p) { return p.directionSkeleton; },
          [](P& p, const json& j) { p.directionSkeleton = j.is_null() ? j : jsonOrFile(j); });
    s.member(param("direction-curvature", ParamType::Bool, "", false, Range::any(),
                 "W = principal direction of largest curvature of the input"),
             &P::directionCurvature);
    ParamInfo singular = param("singular", ParamType::Text, "", "auto", Range::any(),
                             "Near frame singularities: cancel the noise, or fade to isotropic "
                             "noise; auto = isotropic for curvature and skeleton frames, cancel "
                             "for an axis");
    singular.choices = {"auto", "cancel", "isotropic"};
    s.member(singular, &P::singular);
    s.member(seedRow(), &P::seed);
    s.add(param("blend", ParamType::Json, "", nullptr, Range::any(),
                 "Blend towards a second parameter set where the blend mask reads 1: a JSON file "
                 "(or object) with warp_amplitude, gabor_amplitude, gabor_frequency, "
                 "gabor_orientation, gabor_falloff, tilt; the parameters are interpolated, not "
                 "the results"),
          [](const P& p) { return p.blend; },
          [](P& p, const json& j) { p.blend = j.is_null() ? j : jsonOrFile(j); });
    addBakeRows(s, &P::bake, nullptr, nullptr, " [default: the input's]");
    s.rule([](const P& p) {
        const int directions = int(p.directionAxis.has_value()) +
                               int(!p.directionSkeleton.is_null()) + int(p.directionCurvature);
        if (directions > 1) {
            fail<ValueError>("detail: give one of direction-axis, direction-skeleton, "
                             "direction-curvature");
        }
    });
    // Front-ends' groups (the Blender add-on's sub-panels): the warp is Shape.
    s.group("Gabor", {"gabor-amplitude", "gabor-frequency", "gabor-bandwidth", "gabor-orientation",
                      "gabor-impulses", "gabor-falloff", "gabor-isotropic", "tilt"});
    s.group("Direction", {"direction-axis", "direction-skeleton", "direction-curvature", "singular",
                          "blend"});
    return s;
}

} // namespace

const Schema<DetailStageParams>& detailSchema()
{
    static const Schema<DetailStageParams> s = makeSchema();
    return s;
}

DetailStageParams::DetailStageParams() { detailSchema().reset(*this); }

DetailParams DetailParams::fromJson(const json& j) { return detailSchema().fromJson(j).engine(); }

DetailParams DetailStageParams::engine() const
{
    detailSchema().validate(*this);
    DetailParams p;
    p.warp.amplitude = warpAmplitude;
    if (warpRelief != "turbulence") p.warp.image = warpRelief;
    p.warp.scale = warpScale;
    p.warp.octaves = warpOctaves;
    p.warp.sharpness = warpSharpness;
    GaborParams& g = p.gabor;
    g.amplitude = gaborAmplitude;
    g.frequency = gaborFrequency;
    g.bandwidth = gaborBandwidth;
    g.orientationDeg = gaborOrientation;
    g.impulses = gaborImpulses;
    g.falloff = gaborFalloff;
    g.isotropic = gaborIsotropic;
    g.tiltDeg = tilt[0];
    g.tiltAzimuthDeg = tilt[1];
    g.singular = singular == "cancel" ? Singular::Cancel
               : singular == "isotropic" ? Singular::Isotropic : Singular::Auto;
    p.seed = g.seed = seed;
    if (directionAxis) {
        const auto& a = *directionAxis;
        p.direction.axis = Vec3d(a[0], a[1], a[2]);
    } else if (!directionSkeleton.is_null()) {
        p.direction = DirectionField::fromSkeletonJson(jsonOrFile(directionSkeleton));
    } else if (directionCurvature) {
        p.direction.kind = DirectionKind::Curvature;
    }
    if (!blend.is_null()) {
        const json b = jsonOrFile(blend);
        if (!b.is_object()) fail<ValueError>("detail: blend must be a JSON object");
        // Keys as in Python (warp_amplitude) or as on the command line (warp-amplitude).
        json k = json::object();
        for (auto it = b.begin(); it != b.end(); ++it) {
            std::string key = it.key();
            std::replace(key.begin(), key.end(), '-', '_');
            static const char* names[] = {"warp_amplitude", "gabor_amplitude", "gabor_frequency",
                                          "gabor_orientation", "gabor_falloff", "tilt"};
            if (std::find_if(std::begin(names), std::end(names),
                             [&](const char* n) { return key == n; }) == std::end(names)) {
                fail<ValueError>("detail: blend: '", it.key(), "' cannot vary in space (it can: "
                                 "warp_amplitude, gabor_amplitude, gabor_frequency, "
                                 "gabor_orientation, gabor_falloff, tilt)");
            }
            k[key] = it.value();
        }
        try {
            auto bp = std::make_shared<BlendParams>();
            bp->warpAmplitude = k.value("warp_amplitude", p.warp.amplitude);
            bp->gaborAmplitude = k.value("gabor_amplitude", g.amplitude);
            bp->frequency = k.value("gabor_frequency", g.frequency);
            bp->orientationDeg = k.value("gabor_orientation", g.orientationDeg);
            bp->falloff = k.value("gabor_falloff", g.falloff);
            bp->tiltDeg = g.tiltDeg;
            bp->tiltAzimuthDeg = g.tiltAzimuthDeg;
            if (k.contains("tilt")) {
                const auto t = k.at("tilt").get<std::array<double, 2>>();
                bp->tiltDeg = t[0];
                bp->tiltAzimuthDeg = t[1];
            }
            p.blend = bp;
        } catch (const json::exception& e) {
            fail<ValueError>("detail: blend: malformed value (", e.what(), ")");
        }
    }
    return p;
}

DetailResult runDetail(const DetailStageParams& params, const DetailInputs& in, Task& task)
{
    if (!in.grid) fail<ValueError>("detail: no input grid");
    requireLevelSet(*in.grid, "detail input");
    DetailParams p = params.engine();
    if (!params.blend.is_null() && !in.blendMask) {
        fail<ValueError>("detail: blend needs a blend mask (--blend-mask / blend_mask: the weights)");
    }
    if (in.blendMask && params.blend.is_null()) {
        fail<ValueError>("detail: a blend mask needs blend (--blend / blend: the parameters)");
    }
    if (in.blendMask) {
        // Weights, so in [0, 1]: a 5, a −3 or a NaN is a wrong grid, not something to clamp.
        const openvdb::FloatGrid& m = *in.blendMask;
        auto bad = [](float v) { return !(v >= -1e-6f && v <= 1.0f + 1e-6f); };
        if (bad(m.background())) {
            fail<ValueError>("detail: blend mask '", m.getName(), "' has background ", m.background(),
                             "; its weights must be in [0, 1]");
        }
        for (auto it = m.cbeginValueAll(); it; ++it) {
            if (bad(*it)) {
                const auto ijk = it.getCoord();
                fail<ValueError>("detail: blend mask '", m.getName(), "' holds ", *it, " at voxel (",
                                 ijk.x(), ", ", ijk.y(), ", ", ijk.z(), "); its weights must be in [0, 1]");
            }
        }
    }
    p.blendMask = in.blendMask;
    const double dx = in.grid->voxelSize()[0];
    BakeSettings settings = params.bake.settings(dx, double(in.grid->background()) / dx);
    settings.gridName = in.grid->getName().empty() ? "surface" : in.grid->getName();

    task.phase("detail", in.ids.empty() ? 1.0 : 0.9);
    DetailResult r;
    // The input widened for the bake: the ids' walk to the input surface needs its distances
    // as far as the detailed band reaches.
    openvdb::FloatGrid::ConstPtr wide;
    r.bake = detailLevelSet(in.grid, p, settings, task.interrupter(), &wide);
    task.check();

    // Provenance: the table as used (voxel size and band resolved), the inputs' names, and
    // the input's own provenance (skipped by a replay).
    json prov = detailSchema().toJson(params);
    prov["voxel-size"] = settings.voxelSize;
    prov["half-width"] = settings.halfWidth;
    for (auto it = in.names.begin(); it != in.names.end(); ++it) prov[it.key()] = it.value();
    if (auto src = provenance(*in.grid)) {
        prov["sources"] = json::array({{{"generator", src->generator},
                                        {"params", jsonOrText(src->params)}}});
    }
    if (!in.ids.empty()) {
        task.phase("ids", 0.1);
        std::vector<const openvdb::FloatGrid*> ids;
        for (const auto& g : in.ids) ids.push_back(g.get());
        r.ids = carryAttributes(*wide, *r.bake.surface, ids, task.interrupter());
        task.check();
    }
    openvdb::GridPtrVec grids{r.bake.surface};
    grids.insert(grids.end(), r.ids.begin(), r.ids.end());
    stampResult(r, kDetailTool, grids, prov);
    task.done();
    const BakeStats& st = r.bake.stats;
    char line[200];
    std::snprintf(line, sizeof line, "bake: %zu active voxels in %zu leaves (%zu candidates, "
                  "%.1f M evaluations), cull %.3f s, fill %.3f s, finish %.3f s",
                  st.activeVoxels, st.leaves, st.candidateLeaves,
                  double(st.fieldEvaluations) / 1e6, st.cullSeconds, st.fillSeconds,
                  st.finishSeconds);
    r.report.push_back(line);
    r.stats = {{"bake", bakeStatsJson(st)}, {"phases", phasesJson(task)}};
    return r;
}

} // namespace detail
} // namespace rockvdb
