// SPDX-License-Identifier: Apache-2.0
// rockvdb — glTF 2.0 binary (GLB) assets (issue 37): one node per LOD, named <name>_LOD0,
// <name>_LOD1, ... as Unreal's and Unity's importers group them; each a mesh with POSITION,
// NORMAL, TANGENT and TEXCOORD_0 and its own PBR material, whose normalTexture (and
// occlusionTexture, when baked) are the maps baked on that LOD's atlas (PNG, 8 or 16 bits, in
// the binary chunk). A collision hull is a node UCX_<name>_00 (Unreal's and Godot's naming
// for convex collision) with POSITION only and no material. Metres, y up as glTF requires: rockvdb's (x, y, z) is written
// (x, z, -y), a rotation, so windings, normals and tangents' handedness carry over; glTF's
// texture v runs down, so v is written 1 - v. The rockvdb provenance sits in the asset's
// extras ("rockvdb": version, generator, params). Written with tinygltf; the same asset gives
// the same bytes. Several assets can share one file (a pile's unique rocks), each drawn at its
// instances' positions by EXT_mesh_gpu_instancing (TRANSLATION per instance on every node of
// the asset; listed in extensionsUsed, not extensionsRequired: a reader without it draws each
// rock once, at its pivot).
#pragma once

#include <rockvdb/asset/Maps.h>

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace rockvdb {
namespace asset {

struct GltfLod
{
    const UvMesh* mesh = nullptr;
    const VertexFrames* frames = nullptr;
    const BakedMaps* maps = nullptr; ///< baked on this mesh's atlas, or none
};

struct GltfAsset
{
    std::string name = "rock";
    std::vector<GltfLod> lods; ///< finest first
    const TriMesh* collision = nullptr; ///< a convex hull, or none
    int mapBits = 8;           ///< PNG bits per channel: 8 or 16
    /// The id grid baked into BakedMaps::mask (when there is one): a grey PNG per LOD, the id
    /// in each texel and 2^bits - 1 where none is, referenced from the material's extras
    /// {"rockvdb_mask": {"index": texture, "grid": name, "none": 2^bits - 1}} (glTF has no
    /// slot for an id mask).
    std::string maskName = "mask";
    nlohmann::json extras = nlohmann::json::object();
    /// Subtracted from every vertex (rockvdb's world, m): the mesh's origin.
    openvdb::Vec3d pivot = openvdb::Vec3d(0.0);
    /// Where copies of the asset's pivot stand (rockvdb's world, m), written as
    /// EXT_mesh_gpu_instancing translations; none: the asset stands once, at the origin.
    std::vector<openvdb::Vec3d> instances;
};

/// @brief The asset as GLB bytes (its extras are the file's). @throw ValueError for an asset
/// without LODs.
std::string writeGlb(const GltfAsset& asset);

/// @brief Several assets in one GLB (one scene named @a scene, nodes in the assets' order;
/// each asset's extras on its first node, @a extras the file's).
/// @throw ValueError for no assets or an asset without LODs.
std::string writeGlb(const std::vector<GltfAsset>& assets, const std::string& scene,
                     const nlohmann::json& extras);

} // namespace asset
} // namespace rockvdb
