// SPDX-License-Identifier: Apache-2.0
// rockvdb — level set to polygon mesh (tools::volumeToMesh) and OBJ / PLY export.
#pragma once

#include <rockvdb/core/Schema.h>

#include <openvdb/openvdb.h>

#include <string>
#include <vector>

namespace rockvdb {

struct Mesh
{
    std::vector<openvdb::Vec3s> points;   ///< world positions (m)
    std::vector<openvdb::Vec3I> triangles; ///< outward (counter-clockwise) winding
    std::vector<openvdb::Vec4I> quads;     ///< outward (counter-clockwise) winding
    /// Optional part id per triangle and per quad (e.g. one block each): OBJ writes one
    /// object "<groupName>_<id>" per part, PLY a face property "<groupName>".
    std::vector<int> triangleGroups, quadGroups;
    std::string groupName = "part";
    /// Optional unit normal per point: OBJ "vn" (faces v//vn), PLY nx ny nz.
    std::vector<openvdb::Vec3s> normals;
    /// Optional texture coordinates (OBJ "vt") and, per triangle, the indices of its corners'
    /// uvs (faces v/vt/vn): a point on a UV seam has a uv per side. Triangle meshes only.
    std::vector<openvdb::Vec2s> uvs;
    std::vector<openvdb::Vec3I> triangleUvs;
    /// Optional integer ids per point, by name (block_id, rock_id, material): PLY writes a
    /// vertex property each; OBJ, which has no vertex attributes, puts each face under
    /// `usemtl <name>_<id>` of the first one (the id most of its corners hold): Blender makes a
    /// material slot per id, Houdini a shop_materialpath primitive attribute.
    std::vector<std::pair<std::string, std::vector<int>>> pointIds;
};

/// @brief Ids for @a mesh's points from the id grid @a ids (same index space as the level set
/// @a surface it was meshed from): per point, the id of the nearest of its cell's 8 voxels that
/// holds one (>= 0), nearest to the surface first. Stored as pointIds[name].
void attachIds(Mesh& mesh, const openvdb::FloatGrid& surface, const openvdb::FloatGrid& ids,
               const std::string& name);

/// Up axis of a mesh file. rockvdb's world is z up; Blender's OBJ exporter (default settings:
/// forward −Z, up Y) and Houdini are y up. A y-up file point (X, Y, Z) is our (X, −Z, Y), a
/// rotation of −90° about x (orientation and winding are kept), so a mesh exported from
/// Blender lands where it stood in Blender's z-up scene.
enum class UpAxis { Z, Y };

/// @brief "z" or "y" (ValueError naming @a what otherwise).
UpAxis upAxisFromString(const std::string& s, const std::string& what = "up axis");

/// @brief Rotate @a mesh's points from file coordinates with up axis @a up to ours (z up).
void toZUp(Mesh& mesh, UpAxis up);
/// @brief Rotate @a mesh's points from ours (z up) to file coordinates with up axis @a up.
void fromZUp(Mesh& mesh, UpAxis up);

/// @brief Mesh the @a isovalue surface of a level set; outward-facing polygons.
/// @param adaptivity  0 (uniform) .. 1 (most adaptive), as tools::volumeToMesh
Mesh meshLevelSet(const openvdb::FloatGrid& grid, double isovalue = 0.0, double adaptivity = 0.0);

/// vdb_mesh's options, rockvdb.mesh's keywords (defaults in meshSchema()).
struct MeshParams
{
    MeshParams();
    double isovalue;   ///< m
    double adaptivity; ///< 0 (uniform) .. 1
    std::string up;    ///< the file's up axis: "z" or "y"
};

/// @brief The table of MeshParams (op "mesh").
const Schema<MeshParams>& meshSchema();

/// @brief vdb_mesh and rockvdb.mesh: mesh @a grid (a level set) at the table's values.
/// @throw ValueError for a grid that is not a level set, or an isovalue outside its band
/// (an empty mesh).
Mesh meshGrid(const openvdb::FloatGrid& grid, const MeshParams& params);

/// @brief Signed volume enclosed by the mesh (divergence theorem); > 0 for outward winding.
double signedVolume(const Mesh& mesh);

/// @brief Write @a mesh atomically as OBJ (text) or PLY (binary little-endian), chosen by
/// the extension of @a path; "-" writes OBJ to stdout. @a up: the file's up axis.
void writeMesh(const Mesh& mesh, const std::string& path, UpAxis up = UpAxis::Z);

/// @brief Append @a other to @a mesh (indices offset), e.g. one mesh per block; with
/// @a group >= 0 its faces are tagged as that part.
void appendMesh(Mesh& mesh, const Mesh& other, int group = -1);

/// @brief Read a polygon mesh: OBJ (v / f, polygons fanned into triangles), STL (ASCII or
/// binary) or PLY (ASCII or binary little-endian; vertex x y z and a face index list), by
/// extension. STL vertices are welded by exact position.
/// @a up: the file's up axis (points are returned z up).
/// @throw IoError when unreadable, ValueError when malformed (with the file and line).
Mesh readMesh(const std::string& path, UpAxis up = UpAxis::Z);

/// @brief ValueError("<what>: ... is not closed ...") unless every edge of @a mesh is shared
/// by exactly two faces, used once in each direction (a closed, consistently oriented
/// surface: what a point membership needs).
void requireClosed(const Mesh& mesh, const std::string& what);

/// @brief A closed mesh as a narrow-band level set (tools::meshToLevelSet) with voxel size
/// @a voxelSize and band half widths in voxels outside / inside the surface.
openvdb::FloatGrid::Ptr meshToLevelSet(const Mesh& mesh, double voxelSize, double exterior,
                                       double interior);

} // namespace rockvdb
