// SPDX-License-Identifier: Apache-2.0
// GLB assets (asset/Gltf.h), read back with tinygltf: LOD nodes and their triangles, every
// attribute, y up, v flipped, the normal and occlusion textures embedded (8 and 16 bits), a
// convex collision node, provenance in extras; the same asset gives the same bytes.
#include <rockvdb/asset/Gltf.h>
#include <rockvdb/core/Error.h>

#include <gtest/gtest.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <tiny_gltf.h>

#include <cstring>

using namespace rockvdb;
using namespace rockvdb::asset;

namespace {

template<typename T>
std::vector<T> read(const tinygltf::Model& m, int accessor, int components)
{
    const auto& a = m.accessors[accessor];
    const auto& v = m.bufferViews[a.bufferView];
    std::vector<T> out(a.count * components);
    std::memcpy(out.data(), m.buffers[v.buffer].data.data() + v.byteOffset + a.byteOffset,
                out.size() * sizeof(T));
    return out;
}

struct Built
{
    std::vector<Lod> lods;
    std::vector<UvMesh> meshes;
    std::vector<VertexFrames> frames;
    std::vector<BakedMaps> maps;
    TriMesh hull;
};

Built builtSphere()
{
    // a sphere of radius 1 centred at z = 2: its top at z = 3 must become y = 3
    auto g = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(1.0f, openvdb::Vec3f(0, 0.5f, 2), 0.04f, 3.0f);
    Built b;
    Task task;
    b.lods = makeLods(surfaceMesh(*g), {1200, 300}, task);
    for (const Lod& l : b.lods) {
        b.meshes.push_back(atlas(l.mesh, 128, 2));
        b.frames.push_back(vertexFrames(b.meshes.back()));
    }
    const Occlusion occ = occlusion(b.lods[0].mesh, 0.04, 0.5, task);
    for (size_t i = 0; i < b.meshes.size(); ++i) {
        b.maps.push_back(bakeMaps(b.meshes[i], b.frames[i], *g, 128, &occ, task));
    }
    // a tetrahedron as the collision hull: y up like the rest
    b.hull.points = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {0, 0, 2}};
    b.hull.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    return b;
}

std::string glb(const Built& b, int bits = 8, bool collision = false)
{
    GltfAsset a;
    a.name = "boulder";
    a.mapBits = bits;
    if (collision) a.collision = &b.hull;
    for (size_t i = 0; i < b.meshes.size(); ++i) {
        a.lods.push_back({&b.meshes[i], &b.frames[i], &b.maps[i]});
    }
    a.extras = {{"rockvdb", {{"version", "1.2.3"}, {"generator", "vdb_asset"}, {"params", {{"seed", 4}}}}}};
    return writeGlb(a);
}

// GLB bytes read back by tinygltf, images decoded with their own channels (RGB as RGB, grey
// as grey; tinygltf's default makes every image RGBA).
::testing::AssertionResult load(const std::string& bytes, tinygltf::Model& m)
{
    tinygltf::TinyGLTF loader;
    loader.SetPreserveImageChannels(true);
    std::string err, warn;
    if (loader.LoadBinaryFromMemory(&m, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                                    unsigned(bytes.size()))) {
        return ::testing::AssertionSuccess();
    }
    return ::testing::AssertionFailure() << err;
}

} // namespace

TEST(Gltf, GlbReadsBackWithLodsAttributesYUpAndProvenance)
{
    const Built b = builtSphere();
    const std::string bytes = glb(b);
    tinygltf::Model m;
    ASSERT_TRUE(load(bytes, m));
    ASSERT_EQ(m.nodes.size(), 2u);
    EXPECT_EQ(m.nodes[0].name, "boulder_LOD0");
    EXPECT_EQ(m.nodes[1].name, "boulder_LOD1");
    ASSERT_EQ(m.images.size(), 4u); // a normal and an occlusion map per LOD
    for (const auto& im : m.images) {
        EXPECT_EQ(im.mimeType, "image/png");
        EXPECT_EQ(im.width, 128); // tinygltf decoded the embedded PNG
        EXPECT_EQ(im.bits, 8);
    }
    for (size_t l = 0; l < 2; ++l) {
        const auto& prim = m.meshes[m.nodes[l].mesh].primitives[0];
        const auto& mat = m.materials[prim.material];
        EXPECT_EQ(mat.name, "boulder_LOD" + std::to_string(l));
        const auto& normal = m.images[m.textures[mat.normalTexture.index].source];
        EXPECT_EQ(normal.component, 3);
        EXPECT_EQ(normal.name, "boulder_LOD" + std::to_string(l) + "_normal");
        ASSERT_GE(mat.occlusionTexture.index, 0);
        const auto& occ = m.images[m.textures[mat.occlusionTexture.index].source];
        EXPECT_EQ(occ.name, "boulder_LOD" + std::to_string(l) + "_occlusion");
        EXPECT_EQ(occ.component, 1);
        // a sphere is open to the sky all round: every texel near 1 (decoded as read)
        int darkest = 255;
        for (size_t i = 0; i < occ.image.size(); i += size_t(occ.component)) darkest = std::min(darkest, int(occ.image[i]));
        EXPECT_GE(darkest, 240);
        // the texture's image rows: row 0 is v = 0 at the top, the baked map's last row
        const auto& baked = b.maps[l].normal;
        for (int x = 0; x < 128; x += 17) {
            for (int k = 0; k < 3; ++k) {
                EXPECT_EQ(int(normal.image[size_t(x) * 3 + k]),
                          int(std::lround(baked[size_t(127) * 128 + x][k] * 255.0f)));
            }
        }
        const auto idx = read<uint32_t>(m, prim.indices, 1);
        EXPECT_EQ(idx.size(), b.meshes[l].indices.size());
        const auto pos = read<float>(m, prim.attributes.at("POSITION"), 3);
        const auto uv = read<float>(m, prim.attributes.at("TEXCOORD_0"), 2);
        const auto nrm = read<float>(m, prim.attributes.at("NORMAL"), 3);
        const auto tan = read<float>(m, prim.attributes.at("TANGENT"), 4);
        ASSERT_EQ(pos.size(), 3 * b.meshes[l].points.size());
        float top = -1e9f, low = 1e9f;
        for (size_t v = 0; v < pos.size() / 3; ++v) {
            const auto& p = b.meshes[l].points[v];
            EXPECT_EQ(pos[3 * v], p.x());
            EXPECT_EQ(pos[3 * v + 1], p.z());  // up
            EXPECT_EQ(pos[3 * v + 2], -p.y());
            top = std::max(top, pos[3 * v + 1]);
            low = std::min(low, pos[3 * v + 1]);
            EXPECT_FLOAT_EQ(uv[2 * v + 1], 1.0f - b.meshes[l].uvs[v].y());
            EXPECT_GE(uv[2 * v], 0.0f);
            EXPECT_LE(uv[2 * v], 1.0f);
            // outward normals: from the centre (0, 2, -0.5 in glTF) to the point
            const openvdb::Vec3f c(0, 2, -0.5f), q(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]);
            EXPECT_GT(openvdb::Vec3f(nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2]).dot(q - c), 0.0f);
            EXPECT_TRUE(tan[4 * v + 3] == 1.0f || tan[4 * v + 3] == -1.0f);
        }
        EXPECT_NEAR(top, 3.0f, 0.05f);
        EXPECT_NEAR(low, 1.0f, 0.05f);
        EXPECT_EQ(int(m.accessors[prim.attributes.at("POSITION")].maxValues.size()), 3);
    }
    const auto& extras = m.asset.extras.Get("rockvdb");
    EXPECT_EQ(extras.Get("generator").Get<std::string>(), "vdb_asset");
    EXPECT_EQ(extras.Get("params").Get("seed").Get<int>(), 4);
}

TEST(Gltf, SixteenBitMapsAndACollisionHull)
{
    const Built b = builtSphere();
    const std::string bytes = glb(b, 16, true);
    tinygltf::Model m;
    ASSERT_TRUE(load(bytes, m));
    for (const auto& im : m.images) EXPECT_EQ(im.bits, 16);
    const auto& normal = m.images[0];
    const auto* px = reinterpret_cast<const uint16_t*>(normal.image.data());
    for (int x = 0; x < 128; x += 13) {
        EXPECT_EQ(int(px[size_t(x) * 3]), int(std::lround(b.maps[0].normal[size_t(127) * 128 + x][0] * 65535.0f)));
    }
    ASSERT_EQ(m.nodes.size(), 3u);
    const auto& node = m.nodes[2];
    EXPECT_EQ(node.name, "UCX_boulder_00");
    EXPECT_EQ(node.extras.Get("rockvdb_collision").Get<std::string>(), "convex");
    const auto& prim = m.meshes[node.mesh].primitives[0];
    EXPECT_EQ(prim.material, -1);
    EXPECT_EQ(prim.attributes.size(), 1u);
    const auto pos = read<float>(m, prim.attributes.at("POSITION"), 3);
    ASSERT_EQ(pos.size(), 12u);
    EXPECT_EQ(pos[3 * 3 + 1], 2.0f); // the apex (0, 0, 2) is y = 2
    EXPECT_EQ(read<uint32_t>(m, prim.indices, 1).size(), 12u);
}

TEST(Gltf, SameAssetSameBytes)
{
    const Built b = builtSphere();
    EXPECT_EQ(glb(b), glb(b));
    EXPECT_EQ(glb(b), glb(builtSphere()));
    GltfAsset empty;
    EXPECT_THROW(writeGlb(empty), ValueError);
}

TEST(Gltf, AssetsShareAFileEachCentredOnItsPivotAndInstanced)
{
    const Built b = builtSphere();
    GltfAsset one, two;
    one.name = "a";
    two.name = "b";
    for (size_t i = 0; i < b.meshes.size(); ++i) {
        one.lods.push_back({&b.meshes[i], &b.frames[i], &b.maps[i]});
        two.lods.push_back({&b.meshes[i], &b.frames[i], nullptr});
    }
    two.collision = &b.hull;
    // the sphere's centre (0, 0.5, 2) as the pivot: vertices become centred on it
    two.pivot = openvdb::Vec3d(0, 0.5, 2);
    two.instances = {{10, 20, 30}, {-1, -2, -3}};
    two.extras = {{"rockvdb_rock", 7}};
    const std::string bytes = writeGlb({one, two}, "pile", {{"rockvdb", {{"generator", "vdb_asset"}}}});
    tinygltf::Model m;
    ASSERT_TRUE(load(bytes, m));
    ASSERT_EQ(m.scenes.size(), 1u);
    EXPECT_EQ(m.scenes[0].name, "pile");
    ASSERT_EQ(m.nodes.size(), 5u); // a_LOD0, a_LOD1, b_LOD0, b_LOD1, UCX_b_00
    EXPECT_EQ(m.nodes[2].name, "b_LOD0");
    EXPECT_EQ(m.nodes[4].name, "UCX_b_00");
    EXPECT_EQ(m.extensionsUsed, std::vector<std::string>{"EXT_mesh_gpu_instancing"});
    EXPECT_TRUE(m.extensionsRequired.empty());
    EXPECT_EQ(m.images.size(), 4u); // only a's maps
    EXPECT_EQ(m.asset.extras.Get("rockvdb").Get("generator").Get<std::string>(), "vdb_asset");
    EXPECT_EQ(m.nodes[2].extras.Get("rockvdb_rock").Get<int>(), 7);
    EXPECT_TRUE(m.nodes[0].extensions.empty());
    int shared = -1;
    for (size_t n = 2; n < 5; ++n) {
        const auto& ext = m.nodes[n].extensions.at("EXT_mesh_gpu_instancing");
        const int t = ext.Get("attributes").Get("TRANSLATION").Get<int>();
        if (shared < 0) shared = t;
        EXPECT_EQ(t, shared); // every node of b at the same instances
    }
    const auto t = read<float>(m, shared, 3);
    // y up: (10, 20, 30) -> (10, 30, -20)
    EXPECT_EQ(t, (std::vector<float>{10, 30, -20, -1, -3, 2}));
    // a's sphere stays where it is; b's is centred on the pivot
    auto centre = [&](int node) {
        const auto pos = read<float>(m, m.meshes[m.nodes[node].mesh].primitives[0].attributes.at("POSITION"), 3);
        openvdb::Vec3d c(0.0);
        for (size_t v = 0; v < pos.size(); v += 3) c += openvdb::Vec3d(pos[v], pos[v + 1], pos[v + 2]);
        return c / double(pos.size() / 3);
    };
    EXPECT_NEAR((centre(0) - openvdb::Vec3d(0, 2, -0.5)).length(), 0.0, 0.02);
    EXPECT_NEAR(centre(2).length(), 0.0, 0.02);
    EXPECT_THROW(writeGlb(std::vector<GltfAsset>{}, "x", {}), ValueError);
}
