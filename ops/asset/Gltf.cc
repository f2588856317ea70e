// SPDX-License-Identifier: Apache-2.0
#include "Gltf.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Image.h>

#include <tiny_gltf.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <sstream>

namespace rockvdb {
namespace asset {

namespace {

tinygltf::Value toValue(const nlohmann::json& j)
{
    switch (j.type()) {
    case nlohmann::json::value_t::boolean: return tinygltf::Value(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned: return tinygltf::Value(j.get<int>());
    case nlohmann::json::value_t::number_float: return tinygltf::Value(j.get<double>());
    case nlohmann::json::value_t::string: return tinygltf::Value(j.get<std::string>());
    case nlohmann::json::value_t::array: {
        tinygltf::Value::Array a;
        for (const auto& v : j) a.push_back(toValue(v));
        return tinygltf::Value(std::move(a));
    }
    case nlohmann::json::value_t::object: {
        tinygltf::Value::Object o;
        for (const auto& [k, v] : j.items()) o[k] = toValue(v);
        return tinygltf::Value(std::move(o));
    }
    default: return tinygltf::Value();
    }
}

// Bytes appended to the one buffer, 4-byte aligned, as a buffer view; returns its index.
int addView(tinygltf::Model& model, const void* data, size_t bytes, int target)
{
    auto& buf = model.buffers[0].data;
    while (buf.size() % 4) buf.push_back(0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buf.size();
    view.byteLength = bytes;
    view.target = target;
    const auto* p = static_cast<const unsigned char*>(data);
    buf.insert(buf.end(), p, p + bytes);
    model.bufferViews.push_back(view);
    return int(model.bufferViews.size() - 1);
}

int addAccessor(tinygltf::Model& model, int view, int componentType, int type, size_t count,
                std::vector<double> lo = {}, std::vector<double> hi = {})
{
    tinygltf::Accessor a;
    a.bufferView = view;
    a.componentType = componentType;
    a.type = type;
    a.count = count;
    a.minValues = std::move(lo);
    a.maxValues = std::move(hi);
    model.accessors.push_back(a);
    return int(model.accessors.size() - 1);
}

} // namespace

std::string writeGlb(const GltfAsset& asset)
{
    GltfAsset one = asset;
    one.extras = nlohmann::json::object();
    return writeGlb({one}, asset.name, asset.extras);
}

namespace {

// rockvdb's z up to glTF's y up: (x, y, z) -> (x, z, -y), a rotation.
std::array<float, 3> yUp(const openvdb::Vec3d& p)
{
    return {float(p.x()), float(p.z()), float(-p.y())};
}

// A baked map as PNG bytes: the normal map (kind 0, RGB), the occlusion (1, grey: glTF reads
// occlusion from the red channel, a grey image serves every reader) or the id mask (2, grey).
// PNG rows run top down and glTF's v = 0 is the top, so texel row y (v = y / size, bottom up
// in the atlas) is image row size - 1 - y.
std::string mapPng(const BakedMaps& maps, int kind, int bits)
{
    const double top = bits == 16 ? 65535.0 : 255.0;
    const int size = maps.size, channels = kind == 0 ? 3 : 1;
    if (kind == 2) { // the mask: ids as they are, none = top (ids were checked below top)
        std::vector<uint16_t> values(size_t(size) * size);
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                const int32_t id = maps.mask[size_t(y) * size + x];
                values[size_t(size - 1 - y) * size + x] = uint16_t(id < 0 || id >= top ? top : id);
            }
        return encodePng(size, size, 1, bits, values);
    }
    const bool occlusion = kind == 1;
    std::vector<uint16_t> values(size_t(size) * size * channels);
    for (int y = 0; y < size; ++y) {
        for (int x = 0; x < size; ++x) {
            const size_t i = size_t(y) * size + x;
            uint16_t* out = &values[(size_t(size - 1 - y) * size + x) * channels];
            for (int k = 0; k < channels; ++k) {
                const double c = std::clamp(double(occlusion ? maps.occlusion[i] : maps.normal[i][k]), 0.0, 1.0);
                out[k] = uint16_t(std::lround(c * top));
            }
        }
    }
    return encodePng(size, size, channels, bits, values);
}

// One asset's nodes (its LODs, then its collision hull) appended to the model and scene.
void addAsset(tinygltf::Model& model, tinygltf::Scene& scene, const GltfAsset& asset,
              const std::vector<std::array<std::string, 3>>& pngs)
{
    // Instances: one TRANSLATION accessor, shared by the asset's nodes.
    int translations = -1;
    if (!asset.instances.empty()) {
        std::vector<float> t;
        t.reserve(3 * asset.instances.size());
        for (const openvdb::Vec3d& p : asset.instances) {
            const auto q = yUp(p);
            t.insert(t.end(), q.begin(), q.end());
        }
        translations = addAccessor(model, addView(model, t.data(), t.size() * 4, 0),
                                   TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, asset.instances.size());
        const std::string ext = "EXT_mesh_gpu_instancing";
        if (std::find(model.extensionsUsed.begin(), model.extensionsUsed.end(), ext) == model.extensionsUsed.end()) {
            model.extensionsUsed.push_back(ext);
        }
    }
    auto addNode = [&](tinygltf::Node node) {
        if (translations >= 0) {
            tinygltf::Value::Object attributes{{"TRANSLATION", tinygltf::Value(translations)}};
            node.extensions["EXT_mesh_gpu_instancing"] =
                tinygltf::Value(tinygltf::Value::Object{{"attributes", tinygltf::Value(std::move(attributes))}});
        }
        model.nodes.push_back(std::move(node));
        scene.nodes.push_back(int(model.nodes.size() - 1));
    };
    const openvdb::Vec3d pivot = asset.pivot;
    // A texture from its PNG bytes (mapPng).
    auto addTexture = [&](const std::string& name, const std::string& png) {
        tinygltf::Image image;
        image.name = name;
        image.mimeType = "image/png";
        image.bufferView = addView(model, png.data(), png.size(), 0);
        model.images.push_back(image);
        if (model.samplers.empty()) {
            tinygltf::Sampler sampler;
            sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
            sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
            sampler.wrapS = sampler.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
            model.samplers.push_back(sampler);
        }
        tinygltf::Texture texture;
        texture.source = int(model.images.size() - 1);
        texture.sampler = 0;
        model.textures.push_back(texture);
        return int(model.textures.size() - 1);
    };
    // A material per LOD: each LOD's maps are baked on its own atlas.
    auto addMaterial = [&](const std::string& name, const BakedMaps* maps, size_t l) {
        tinygltf::Material material;
        material.name = name;
        material.pbrMetallicRoughness.metallicFactor = 0.0;
        material.pbrMetallicRoughness.roughnessFactor = 0.9;
        material.pbrMetallicRoughness.baseColorFactor = {0.45, 0.42, 0.39, 1.0};
        if (maps) {
            material.normalTexture.index = addTexture(name + "_normal", pngs[l][0]);
            if (!maps->occlusion.empty()) {
                material.occlusionTexture.index = addTexture(name + "_occlusion", pngs[l][1]);
            }
            if (!maps->mask.empty()) {
                const int index = addTexture(name + "_" + asset.maskName, pngs[l][2]);
                const tinygltf::Value::Object mask{
                    {"index", tinygltf::Value(index)}, {"grid", tinygltf::Value(asset.maskName)},
                    {"none", tinygltf::Value(asset.mapBits == 16 ? 65535 : 255)}};
                material.extras = tinygltf::Value(tinygltf::Value::Object{{"rockvdb_mask", tinygltf::Value(mask)}});
            }
        }
        model.materials.push_back(material);
        return int(model.materials.size() - 1);
    };

    for (size_t l = 0; l < asset.lods.size(); ++l) {
        const UvMesh& m = *asset.lods[l].mesh;
        const VertexFrames& f = *asset.lods[l].frames;
        const size_t nv = m.points.size();
        std::vector<float> pos(3 * nv), nrm(3 * nv), tan(4 * nv), uv(2 * nv);
        std::vector<double> lo(3, 1e300), hi(3, -1e300);
        for (size_t v = 0; v < nv; ++v) {
            const auto q = yUp(openvdb::Vec3d(m.points[v]) - pivot);
            for (int k = 0; k < 3; ++k) {
                pos[3 * v + k] = q[k];
                lo[k] = std::min(lo[k], double(q[k]));
                hi[k] = std::max(hi[k], double(q[k]));
            }
            const openvdb::Vec3f& n = f.normals[v];
            nrm[3 * v] = n.x(), nrm[3 * v + 1] = n.z(), nrm[3 * v + 2] = -n.y();
            const openvdb::Vec4f& t = f.tangents[v];
            tan[4 * v] = t[0], tan[4 * v + 1] = t[2], tan[4 * v + 2] = -t[1], tan[4 * v + 3] = t[3];
            uv[2 * v] = m.uvs[v].x();
            uv[2 * v + 1] = 1.0f - m.uvs[v].y();
        }
        tinygltf::Primitive prim;
        prim.mode = TINYGLTF_MODE_TRIANGLES;
        prim.material = addMaterial(asset.name + "_LOD" + std::to_string(l), asset.lods[l].maps, l);
        prim.attributes["POSITION"] = addAccessor(
            model, addView(model, pos.data(), pos.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv, lo, hi);
        prim.attributes["NORMAL"] = addAccessor(
            model, addView(model, nrm.data(), nrm.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
        prim.attributes["TANGENT"] = addAccessor(
            model, addView(model, tan.data(), tan.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, nv);
        prim.attributes["TEXCOORD_0"] = addAccessor(
            model, addView(model, uv.data(), uv.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
        prim.indices = addAccessor(
            model, addView(model, m.indices.data(), m.indices.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, m.indices.size());
        tinygltf::Mesh mesh;
        mesh.name = asset.name + "_LOD" + std::to_string(l);
        mesh.primitives.push_back(prim);
        model.meshes.push_back(mesh);
        tinygltf::Node node;
        node.name = mesh.name;
        node.mesh = int(model.meshes.size() - 1);
        if (l == 0 && !asset.extras.empty()) node.extras = toValue(asset.extras);
        addNode(std::move(node));
    }
    if (asset.collision && asset.collision->triangles()) {
        const TriMesh& c = *asset.collision;
        std::vector<float> pos(3 * c.points.size());
        std::vector<double> lo(3, 1e300), hi(3, -1e300);
        for (size_t v = 0; v < c.points.size(); ++v) {
            const auto q = yUp(openvdb::Vec3d(c.points[v]) - pivot);
            for (int k = 0; k < 3; ++k) {
                pos[3 * v + k] = q[k];
                lo[k] = std::min(lo[k], double(q[k]));
                hi[k] = std::max(hi[k], double(q[k]));
            }
        }
        tinygltf::Primitive prim;
        prim.mode = TINYGLTF_MODE_TRIANGLES;
        prim.attributes["POSITION"] = addAccessor(
            model, addView(model, pos.data(), pos.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, c.points.size(), lo, hi);
        prim.indices = addAccessor(
            model, addView(model, c.indices.data(), c.indices.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER),
            TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, c.indices.size());
        tinygltf::Mesh mesh;
        mesh.name = "UCX_" + asset.name + "_00";
        mesh.primitives.push_back(prim);
        model.meshes.push_back(mesh);
        tinygltf::Node node;
        node.name = mesh.name;
        node.mesh = int(model.meshes.size() - 1);
        node.extras = tinygltf::Value(tinygltf::Value::Object{{"rockvdb_collision", tinygltf::Value(std::string("convex"))}});
        addNode(std::move(node));
    }
}

} // namespace

std::string writeGlb(const std::vector<GltfAsset>& assets, const std::string& sceneName,
                     const nlohmann::json& extras)
{
    if (assets.empty()) fail<ValueError>("asset: nothing to write (no assets)");
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "rockvdb";
    model.asset.extras = toValue(extras);
    model.buffers.emplace_back();
    tinygltf::Scene scene;
    scene.name = sceneName;
    // Every map's PNG first, side by side (zlib is serial, and a pile has hundreds).
    std::vector<std::vector<std::array<std::string, 3>>> pngs(assets.size());
    std::vector<std::array<size_t, 3>> jobs; // asset, LOD, kind (mapPng)
    for (size_t a = 0; a < assets.size(); ++a) {
        if (assets[a].lods.empty()) fail<ValueError>("asset: nothing to write (no LODs)");
        const int bits = assets[a].mapBits;
        if (bits != 8 && bits != 16) fail<ValueError>("asset: map bits must be 8 or 16 (got ", bits, ")");
        pngs[a].resize(assets[a].lods.size());
        for (size_t l = 0; l < assets[a].lods.size(); ++l) {
            const BakedMaps* maps = assets[a].lods[l].maps;
            if (!maps) continue;
            jobs.push_back({a, l, 0});
            if (!maps->occlusion.empty()) jobs.push_back({a, l, 1});
            if (!maps->mask.empty()) jobs.push_back({a, l, 2});
        }
    }
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t j) {
        const auto [a, l, kind] = jobs[j];
        pngs[a][l][kind] = mapPng(*assets[a].lods[l].maps, int(kind), assets[a].mapBits);
    });
    for (size_t a = 0; a < assets.size(); ++a) addAsset(model, scene, assets[a], pngs[a]);
    model.scenes.push_back(scene);
    model.defaultScene = 0;

    std::ostringstream os(std::ios::binary);
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, os, false, true)) {
        fail<IoError>("asset: cannot write the glTF binary");
    }
    return os.str();
}

} // namespace asset
} // namespace rockvdb
