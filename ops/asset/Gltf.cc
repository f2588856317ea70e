#include "Gltf.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Image.h>

#include <tiny_gltf.h>

#include <algorithm>
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
    if (asset.lods.empty()) fail<ValueError>("asset: nothing to write (no LODs)");
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "rockvdb";
    model.asset.extras = toValue(asset.extras);
    model.buffers.emplace_back();
    tinygltf::Scene scene;
    scene.name = asset.name;

    const int bits = asset.mapBits;
    if (bits != 8 && bits != 16) fail<ValueError>("asset: map bits must be 8 or 16 (got ", bits, ")");
    const double top = bits == 16 ? 65535.0 : 255.0;
    // A texture from a baked channel: PNG rows run top down and glTF's v = 0 is the top, so
    // texel row y (v = y / size, bottom up in the atlas) is image row size - 1 - y.
    auto addTexture = [&](const std::string& name, int size, int channels, auto texel) {
        std::vector<uint16_t> values(size_t(size) * size * channels);
        for (int y = 0; y < size; ++y) {
            for (int x = 0; x < size; ++x) {
                uint16_t* out = &values[(size_t(size - 1 - y) * size + x) * channels];
                for (int k = 0; k < channels; ++k) {
                    const double c = std::clamp(double(texel(size_t(y) * size + x, k)), 0.0, 1.0);
                    out[k] = uint16_t(std::lround(c * top));
                }
            }
        }
        const std::string png = encodePng(size, size, channels, bits, values);
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
    auto addMaterial = [&](const std::string& name, const BakedMaps* maps) {
        tinygltf::Material material;
        material.name = name;
        material.pbrMetallicRoughness.metallicFactor = 0.0;
        material.pbrMetallicRoughness.roughnessFactor = 0.9;
        material.pbrMetallicRoughness.baseColorFactor = {0.45, 0.42, 0.39, 1.0};
        if (maps) {
            material.normalTexture.index = addTexture(name + "_normal", maps->size, 3,
                [&](size_t i, int k) { return maps->normal[i][k]; });
            if (!maps->occlusion.empty()) {
                // glTF reads occlusion from the red channel: a grey image serves every reader
                material.occlusionTexture.index = addTexture(name + "_occlusion", maps->size, 1,
                    [&](size_t i, int) { return maps->occlusion[i]; });
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
            const openvdb::Vec3f& p = m.points[v];
            const float q[3] = {p.x(), p.z(), -p.y()}; // z up -> y up
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
        prim.material = addMaterial(asset.name + "_LOD" + std::to_string(l), asset.lods[l].maps);
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
        model.nodes.push_back(node);
        scene.nodes.push_back(int(model.nodes.size() - 1));
    }
    if (asset.collision && asset.collision->triangles()) {
        const TriMesh& c = *asset.collision;
        std::vector<float> pos(3 * c.points.size());
        std::vector<double> lo(3, 1e300), hi(3, -1e300);
        for (size_t v = 0; v < c.points.size(); ++v) {
            const openvdb::Vec3f& p = c.points[v];
            const float q[3] = {p.x(), p.z(), -p.y()}; // z up -> y up
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
        model.nodes.push_back(node);
        scene.nodes.push_back(int(model.nodes.size() - 1));
    }
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
