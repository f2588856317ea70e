// rockvdb — glTF 2.0 binary (GLB) assets (issue 37): one node per LOD, named <name>_LOD0,
// <name>_LOD1, ... as Unreal's and Unity's importers group them; each a mesh with POSITION,
// NORMAL, TANGENT and TEXCOORD_0 and its own PBR material, whose normalTexture (and
// occlusionTexture, when baked) are the maps baked on that LOD's atlas (PNG, 8 or 16 bits, in
// the binary chunk). A collision hull is a node UCX_<name>_00 (Unreal's and Godot's naming
// for convex collision) with POSITION only and no material. Metres, y up as glTF requires: rockvdb's (x, y, z) is written
// (x, z, -y), a rotation, so windings, normals and tangents' handedness carry over; glTF's
// texture v runs down, so v is written 1 - v. The rockvdb provenance sits in the asset's
// extras ("rockvdb": version, generator, params). Written with tinygltf; the same asset gives
// the same bytes.
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
    nlohmann::json extras = nlohmann::json::object();
};

/// @brief The asset as GLB bytes. @throw ValueError for an asset without LODs.
std::string writeGlb(const GltfAsset& asset);

} // namespace asset
} // namespace rockvdb
