"""The stages the add-on offers: which table rows each operator shows (those its rockvdb
function takes), what it reads from the scene (main thread, bpy) and how it calls rockvdb
(worker thread, no bpy)."""
import os

import bpy
import numpy as np

import rockvdb

from . import results, tables


class Stage:
    """One operator: rockvdb.<name> in Blender.
    tables: [(stage table, rockvdb function, property prefix)];
    needs: None, "mesh" (the active mesh object), "result" (the active rockvdb result);
    run(kw, inputs) -> grids, called off the UI thread."""

    def __init__(self, name, label, icon, tables_, needs, gather, run, optional=False):
        self.name, self.label, self.icon = name, label, icon
        self.needs, self.optional = needs, optional
        self.gather_fn, self.run_fn = gather, run
        self.groups = [(t, tables.rows_of(t, f, prefix), prefix) for t, f, prefix in tables_]
        self.summary = " ".join(tables.table(t)["summary"] for t, _, _ in tables_)

    def rows(self):
        return [r for _, rows, _ in self.groups for r in rows]

    def keywords(self, op):
        """{prefix: keywords} for each table of the stage, from the operator's properties."""
        return {prefix: tables.keywords(op, rows) for _, rows, prefix in self.groups}


# ---------------------------------------------------------------------------------------------
# What stages read from the scene.

def _mesh_arrays(obj, context, close_depth=None):
    """The active mesh, modifiers applied, in world space: (points N x 3, triangles M x 3).
    With close_depth, an open sheet (a terrain) is closed first: its border extruded down to
    close_depth below its lowest point and the hole filled, so it bounds a solid."""
    import bmesh
    depsgraph = context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(depsgraph)
    me = ev.to_mesh()
    bm = bmesh.new()
    bm.from_mesh(me)
    ev.to_mesh_clear()
    bm.transform(obj.matrix_world)
    if close_depth is not None:
        border = [e for e in bm.edges if e.is_boundary]
        if border:
            floor = min(v.co.z for v in bm.verts) - close_depth
            made = bmesh.ops.extrude_edge_only(bm, edges=border)
            new_verts = [g for g in made["geom"] if isinstance(g, bmesh.types.BMVert)]
            for v in new_verts:
                v.co.z = floor
            new_edges = [e for e in bm.edges if e.is_boundary]
            bmesh.ops.holes_fill(bm, edges=new_edges, sides=0)
            bmesh.ops.recalc_face_normals(bm, faces=bm.faces)
    bmesh.ops.triangulate(bm, faces=bm.faces)
    pts = np.array([v.co[:] for v in bm.verts], np.float32)
    index = {v: i for i, v in enumerate(bm.verts)}
    tris = np.array([[index[v] for v in f.verts] for f in bm.faces], np.uint32).reshape(-1, 3)
    bm.free()
    if len(tris) == 0:
        raise ValueError(f"'{obj.name}' has no faces")
    return pts, tris


def _write_obj(path, pts, tris):
    """A triangle mesh as .obj (z up, metres), written whole or not at all."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        np.savetxt(f, pts, fmt="v %.7g %.7g %.7g")
        np.savetxt(f, tris + 1, fmt="f %d %d %d")
    os.replace(tmp, path)


def _active_mesh(context, optional=False):
    obj = context.active_object
    if obj is None or obj.type != "MESH" or obj.get("rockvdb_stage"):
        if optional:
            return None
        raise ValueError("select a mesh object first (the active object is "
                         + (f"'{obj.name}', a {obj.type.lower()}" if obj else "none") + ")")
    return obj


def _active_result(context):
    obj = context.active_object
    if obj is None or not obj.get("rockvdb_stage"):
        raise ValueError("select a rockvdb result first (the active object is "
                         + (f"'{obj.name}'" if obj else "none") + ")")
    return obj


def _gather_none(op, context):
    return {}


def _gather_ground(op, context):
    """fractal_scatter's ground: the active mesh closed into a solid and made a level set at
    the stage's voxel size, or (nothing selected) the plane z = 0."""
    obj = _active_mesh(context, optional=True)
    if obj is None:
        return {"ground": None, "source": ""}
    return {"mesh": _mesh_arrays(obj, context, close_depth=1.0), "source": obj.name}


def _gather_support(op, context):
    """rock_pile's support: the active closed mesh, saved as .obj beside the cache (the pile's
    provenance names that file, so a replay finds it)."""
    obj = _active_mesh(context)
    pts, tris = _mesh_arrays(obj, context)
    path = results.cache_path(obj.name + "_support")[:-4] + ".obj"
    _write_obj(path, pts, tris)
    # The tile set is saved beside it too, and the pile reads it from there: the pile's
    # provenance then names both files, and vdb_rockpile --params replays it.
    tiles = results.cache_path(obj.name + "_rocks")[:-4] + ".tiles"
    return {"support": path, "tiles": tiles, "source": obj.name}


def _gather_result(op, context):
    obj = _active_result(context) if not op.source else bpy.data.objects.get(op.source)
    if obj is None:
        raise ValueError(f"no object '{op.source}' to detail")
    grids = results.grids_of(obj)
    return {"grids": grids, "source": obj.name}


# ---------------------------------------------------------------------------------------------
# How stages call rockvdb (worker thread: no bpy here).

def _run_fractal_rock(kw, inputs):
    surface, _ = rockvdb.fractal_rock(**kw[""])
    return [surface]


def _run_fractal_scatter(kw, inputs):
    import pyopenvdb
    ground = inputs.get("ground")
    if "mesh" in inputs:
        pts, tris = inputs["mesh"]
        # The ground at the rocks' own voxel size and band.
        ground = pyopenvdb.FloatGrid.createLevelSetFromPolygons(
            pts, triangles=tris,
            transform=pyopenvdb.createLinearTransform(voxelSize=kw[""]["voxel_size"]),
            halfWidth=kw[""]["half_width"])
        ground.name = "surface"
    return list(rockvdb.fractal_scatter(ground, **kw[""]))


def _run_block_tile(kw, inputs):
    tile = rockvdb.block_tile(**kw[""])
    return [tile.surface, tile.block_id]


def _run_rock_pile(kw, inputs):
    rockvdb.rock_tiles(path=inputs["tiles"], **kw["tiles_"])
    return list(rockvdb.rock_pile(inputs["tiles"], inputs["support"], **kw[""]))


def _run_detail(kw, inputs):
    grids = inputs["grids"]
    surface = next(g for g in grids if g.name == "surface")
    out = rockvdb.detail(surface, **kw[""])
    # The input's id grids come along: the result's points take the id of the nearest
    # input voxel (detail moves the surface by less than its amplitude).
    return [out] + [g for g in grids if g.name in results.ID_GRIDS]


STAGES = [
    Stage("fractal_rock", "Fractal Rock", "MESH_ICOSPHERE",
          [("fractal_rock", rockvdb.fractal_rock, "")], None, _gather_none, _run_fractal_rock),
    Stage("fractal_scatter", "Fractal Scatter", "PARTICLES",
          [("fractal_scatter", rockvdb.fractal_scatter, "")], "mesh", _gather_ground,
          _run_fractal_scatter, optional=True),
    Stage("block_tile", "Block Tile", "MOD_EXPLODE",
          [("block_tile", rockvdb.block_tile, "")], None, _gather_none, _run_block_tile),
    Stage("rock_pile", "Rock Pile", "OUTLINER_OB_POINTCLOUD",
          [("rock_tiles", rockvdb.rock_tiles, "tiles_"), ("rock_pile", rockvdb.rock_pile, "")],
          "mesh", _gather_support, _run_rock_pile),
    Stage("detail", "Detail", "MOD_DISPLACE",
          [("detail", rockvdb.detail, "")], "result", _gather_result, _run_detail),
]
