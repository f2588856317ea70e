# SPDX-License-Identifier: Apache-2.0
"""The stages the add-on offers: which table rows each operator shows (those its rockvdb
function takes), what it reads from the scene (main thread, bpy) and how it calls rockvdb
(worker thread, no bpy)."""
import json
import os

import bpy
import numpy as np

import rockvdb
from rockvdb import _rockvdb

from . import results, tables


class Stage:
    """One operator: rockvdb.<name> in Blender.
    tables: [(stage table, rockvdb function, property prefix)];
    gather(op, context) -> inputs: what it reads from the scene (UI thread), lengths in metres;
    run(kw, inputs) -> grids, or (grids, {"instances": ...}): called off the UI thread;
    extent(kw, inputs) -> the result's largest extent (m), which the Preview quality's rule
    reads (None: the stage has no voxel size of its own to coarsen, as Detail)."""

    def __init__(self, name, label, icon, description, tables_, gather, run, extra=None,
                 positional=(), extent=None):
        self.name, self.label, self.icon = name, label, icon
        self.gather_fn, self.run_fn, self.extent_fn = gather, run, extent
        self.groups = [(t, tables.rows_of(t, f, prefix, positional), prefix)
                       for t, f, prefix in tables_]
        # The add-on's own properties (how a scene object becomes the stage's input), drawn
        # above the table's rows: {name: bpy property}.
        self.extra = extra or {}
        # Blender's tooltip: one plain sentence, what the artist gets (the tables' summaries,
        # written for the CLI's --help, cite the papers).
        self.summary = description

    def rows(self):
        return [r for _, rows, _ in self.groups for r in rows]

    def keywords(self, op, scale=1.0):
        """{prefix: keywords} for each table of the stage, from the operator's properties
        (lengths times @a scale, Blender's Unit Scale)."""
        return {prefix: tables.keywords(op, rows, scale) for _, rows, prefix in self.groups}

    def default(self, kw, python, prefix=""):
        """The value of row @a python in @a kw, else the table's default (metres)."""
        if python in kw[prefix]:
            return kw[prefix][python]
        return next(r for _, rows, p in self.groups if p == prefix for r in rows
                    if r["python"] == python)["default"]

    def preview(self, kw, inputs):
        """The Preview quality: the voxel size the rule beside the tables gives for this
        result's extent (core/Schema.h previewVoxelSize), set in @a kw; returns it (None: the
        stage keeps its voxel size)."""
        if self.extent_fn is None or not any(r["python"] == "voxel_size" for _, rows, p in self.groups
                                             if p == "" for r in rows):
            return None
        final = self.default(kw, "voxel_size")
        extent = self.extent_fn(self, kw, inputs)
        if final is None or extent is None:
            return None
        voxel = _rockvdb.preview_voxel_size(final, extent)
        # Three significant digits (provenance a person reads), never finer than the final.
        voxel = max(final, float(f"{voxel:.3g}"))
        kw[""]["voxel_size"] = voxel
        return voxel


# ---------------------------------------------------------------------------------------------
# What stages read from the scene.

def unit_scale(context):
    """Blender's Unit Scale: metres per scene unit (rockvdb works in metres), as the decimal
    it shows (Blender keeps it in 32 bits: 0.01 is 0.0099999998)."""
    return tables.decimal(context.scene.unit_settings.scale_length) or 1.0


def _mesh_arrays(obj, context, close_depth=None):
    """The active mesh, modifiers applied, in world space and metres (scene units times the
    Unit Scale): (points N x 3, triangles M x 3). With close_depth (m), an open sheet (a
    terrain) is closed first: its border extruded down to close_depth below its lowest point
    and the hole filled, so it bounds a solid."""
    scale = unit_scale(context)
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
            floor = min(v.co.z for v in bm.verts) - close_depth / scale
            made = bmesh.ops.extrude_edge_only(bm, edges=border)
            new_verts = [g for g in made["geom"] if isinstance(g, bmesh.types.BMVert)]
            for v in new_verts:
                v.co.z = floor
            new_edges = [e for e in bm.edges if e.is_boundary]
            bmesh.ops.holes_fill(bm, edges=new_edges, sides=0)
            bmesh.ops.recalc_face_normals(bm, faces=bm.faces)
    bmesh.ops.triangulate(bm, faces=bm.faces)
    pts = np.array([v.co[:] for v in bm.verts], np.float64) * scale
    pts = pts.astype(np.float32)
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


def _mesh_level_set(mesh, voxel_size, half_width, path):
    """A closed triangle mesh (points, triangles; world space) as a level set 'surface',
    written to @a path (the stage reads it from there, so its provenance names a file and the
    CLI replays it). Worker thread."""
    import pyopenvdb
    pts, tris = mesh
    grid = pyopenvdb.FloatGrid.createLevelSetFromPolygons(
        pts, triangles=tris, transform=pyopenvdb.createLinearTransform(voxelSize=voxel_size),
        halfWidth=half_width)
    grid.name = "surface"
    rockvdb.write(path, [grid])
    return path


def _heightfield(obj, context, cell):
    """The active mesh's heights sampled every @a cell metres from the world origin (pixel
    (i, j) at x = i·cell, y = j·cell, as rockvdb reads heightfields), by rays cast down; a
    column the mesh does not cover takes its lowest height."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree
    pts, tris = _mesh_arrays(obj, context)
    lo, hi = pts.min(0), pts.max(0)  # (per axis)
    if lo[0] < -0.5 * cell or lo[1] < -0.5 * cell:
        raise ValueError(f"a heightfield starts at the world origin: move '{obj.name}' to x, y "
                         f">= 0 (its corner is at {lo[0]:.3g}, {lo[1]:.3g}), or amplify it as "
                         "a level set")
    bvh = BVHTree.FromPolygons([tuple(p) for p in pts], [tuple(t) for t in tris.tolist()])
    nx, ny = int(hi[0] / cell) + 1, int(hi[1] / cell) + 1
    if nx * ny > 16_000_000:
        raise ValueError(f"a {nx} x {ny} heightfield is too large: raise the cell size")
    z = np.full((ny, nx), lo[2], np.float32)
    top = float(hi[2]) + 1.0
    down = Vector((0.0, 0.0, -1.0))
    for j in range(ny):
        for i in range(nx):
            hit = bvh.ray_cast(Vector((i * cell, j * cell, top)), down)
            if hit[0] is not None:
                z[j, i] = hit[0].z
    return z


def _active_mesh(context, optional=False, source=""):
    """The input mesh: the object named @a source (a result's stored input, for Regenerate),
    else the active object."""
    obj = bpy.data.objects.get(source) if source else context.active_object
    if source and obj is None:
        raise ValueError(f"the input object '{source}' is gone")
    if obj is None or obj.type != "MESH" or obj.get("rockvdb_stage"):
        if optional:
            return None
        what = ("none" if obj is None else f"'{obj.name}', a rockvdb result" if obj.get("rockvdb_stage")
                else f"'{obj.name}', a {obj.type.lower()}")
        raise ValueError(f"select a mesh object first (the active object is {what})")
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
    """fractal_scatter's ground: the active mesh (an open sheet closed downward) made a level
    set at the rocks' voxel size, or (nothing selected) the plane z = 0."""
    obj = _active_mesh(context, optional=True, source=op.source)
    if obj is None:
        return {"ground": None, "source": "", "instances": op.instances}
    return {"mesh": _mesh_arrays(obj, context, close_depth=1.0), "source": obj.name,
            "level_set": results.cache_path(obj.name + "_ground"), "instances": op.instances}


def _gather_tile(op, context):
    """Where the block tile is saved (its .tile, for amplify to read): a folder of its own, so
    the file's stem, which strata name tiles by, is the object's name."""
    import uuid
    target = bpy.data.objects.get(op.target) if op.target else None
    name = target.name if target is not None else results.unique_name(op.stage.label)
    folder = os.path.join(results.cache_dir(), uuid.uuid4().hex[:8])
    os.makedirs(folder, exist_ok=True)
    return {"tile": os.path.join(folder, results.safe_name(name) + ".tile")}


def _gather_amplify(op, context):
    """amplify's terrain (the active mesh, as a level set or a heightfield) and tiles (the
    named Block Tile results or .tile files; none named: every Block Tile in the scene)."""
    obj = _active_mesh(context, source=op.source)
    names = [n.strip() for n in op.tiles.split(",") if n.strip()]
    if not names:
        names = sorted(o.name for o in context.scene.objects if o.get("rockvdb_tile"))
        if not names:
            raise ValueError("no block tiles: make one (Add > rockvdb > Block Tile) or name "
                             ".tile files in Tiles")
    tiles = []
    for n in names:
        o = bpy.data.objects.get(n)
        if o is not None and o.get("rockvdb_tile"):
            tile = results.cache_file(o["rockvdb_tile"])
            if not os.path.isfile(tile):
                raise ValueError(f"tiles: the tile file of '{n}' is missing ({tile}): "
                                 "Regenerate it first")
            tiles.append(tile)
        elif n.endswith(".tile") and os.path.isfile(bpy.path.abspath(n)):
            tiles.append(bpy.path.abspath(n))
        else:
            raise ValueError(f"tiles: '{n}' is neither a Block Tile result nor a .tile file")
    inputs = {"tiles": tiles, "source": obj.name}
    if op.terrain_as == "HEIGHTFIELD":
        z = _heightfield(obj, context, tables.decimal(op.cell_size * unit_scale(context)))
        path = results.cache_path(obj.name + "_heights")[:-4] + ".exr"
        rockvdb.write_heightfield(path, z)
        inputs["terrain"] = path
        inputs["heights"] = z
    else:
        inputs["mesh"] = _mesh_arrays(obj, context,
                                      close_depth=tables.decimal(op.base_depth * unit_scale(context)))
        inputs["level_set"] = results.cache_path(obj.name + "_terrain")
    return inputs


def _gather_stacks(op, context):
    """The material stacks' terrain: a vdb_arches scene file, the terrain row's node, or the
    active mesh (an open sheet closed downward) as a level set."""
    if op.scene:
        scene = bpy.path.abspath(op.scene)
        if not os.path.isfile(scene):
            raise ValueError(f"scene: no file '{scene}'")
        # A scene's keys hold unless a property was set (as with vdb_arches' options).
        given = [r["python"] for r in op.stage.rows() if op.properties.is_property_set(r["prop"])]
        return {"scene": scene, "given": given, "source": ""}
    if op.use_terrain:
        return {"source": ""}
    obj = _active_mesh(context, source=op.source)
    return {"mesh": _mesh_arrays(obj, context, close_depth=1.0), "source": obj.name,
            "level_set": results.cache_path(obj.name + "_terrain"),
            "mesh_voxel": tables.decimal(op.mesh_voxel * unit_scale(context))}


def _gather_support(op, context):
    """rock_pile's support: the active closed mesh, saved as .obj beside the cache (the pile's
    provenance names that file, so a replay finds it)."""
    obj = _active_mesh(context, source=op.source)
    pts, tris = _mesh_arrays(obj, context)
    path = results.cache_path(obj.name + "_support")[:-4] + ".obj"
    _write_obj(path, pts, tris)
    # The tile set is saved beside it too, and the pile reads it from there: the pile's
    # provenance then names both files, and vdb_rockpile --params replays it.
    tiles = results.cache_path(obj.name + "_rocks")[:-4] + ".tiles.vdb"
    # (the mesh too: what the redo panel's memo compares, the files being this call's own)
    return {"support": path, "tiles": tiles, "source": obj.name, "instances": op.instances,
            "mesh": (pts, tris)}


def _gather_result(op, context):
    obj = _active_result(context) if not op.source else bpy.data.objects.get(op.source)
    if obj is None:
        raise ValueError(f"the input object '{op.source}' is gone")
    grids = results.grids_of(obj)
    return {"grids": grids, "source": obj.name}


# ---------------------------------------------------------------------------------------------
# How stages call rockvdb (worker thread: no bpy here).

def _run_fractal_rock(kw, inputs):
    surface, _ = rockvdb.fractal_rock(**kw[""])
    return [surface]


def _run_fractal_scatter(kw, inputs):
    ground = inputs.get("ground")
    if "mesh" in inputs:  # the ground at the rocks' own voxel size and band
        ground = _mesh_level_set(inputs["mesh"], kw[""]["voxel_size"], kw[""]["half_width"],
                                 inputs["level_set"])
    if not inputs.get("instances"):
        return list(rockvdb.fractal_scatter(ground, **kw[""]))
    stats = {}
    *grids, mesh = rockvdb.fractal_scatter(ground, stats=stats, mesh=True, **kw[""])
    return grids, {"instances": _scatter_instances(mesh, stats)}


def _quat_to_matrix(q):
    """Rotation matrix of a unit quaternion (x, y, z, w)."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _scatter_instances(mesh, stats):
    """The scattered rocks as instances: each rock's mesh in its own frame (its seed at the
    origin, unrotated: R^T (p - position)), and per instance its position, orientation
    (quaternion x, y, z, w, as the CLI's points grid 'orient') and scale (pscale 1)."""
    pts, tris, rock = mesh["points"], mesh["triangles"], mesh["rock"]
    rocks = []
    for r, (pos, q) in enumerate(zip(stats["positions"], stats["orients"])):
        faces = tris[rock == r]
        used = np.unique(faces)
        remap = np.full(len(pts), -1, np.int64)
        remap[used] = np.arange(len(used))
        local = (pts[used] - pos) @ _quat_to_matrix(q)  # row vectors: R^T (p - pos)
        rocks.append({"points": local.astype(np.float32), "triangles": remap[faces]})
    n = len(rocks)
    return {"rocks": rocks, "positions": np.asarray(stats["positions"], np.float64),
            "orients": np.asarray(stats["orients"], np.float64),
            "pscale": np.ones(n, np.float32), "rock_id": np.arange(n)}  # ids: placement order


def _run_block_tile(kw, inputs):
    tile = rockvdb.block_tile(**kw[""])
    tile.save(inputs["tile"])
    return [tile.surface, tile.block_id]


def _run_amplify(kw, inputs):
    terrain = inputs.get("terrain")
    if "mesh" in inputs:  # the terrain at the bake's voxel size and band
        terrain = _mesh_level_set(inputs["mesh"], kw[""]["voxel_size"], kw[""]["half_width"],
                                  inputs["level_set"])
    return list(rockvdb.amplify(terrain, inputs["tiles"], **kw[""]))


def _run_stacks(kw, inputs):
    kw = dict(kw[""])
    if "scene" in inputs:
        kw = {k: v for k, v in kw.items() if k in inputs["given"]}
        kw.pop("terrain", None)
        bake = {k: kw.pop(k) for k in list(kw) if k in rockvdb.Stacks.BAKE_ROWS}
        stacks = rockvdb.Stacks.from_scene(inputs["scene"], **kw)
    else:
        terrain = kw.pop("terrain", None)
        if "mesh" in inputs:
            # The mesh at the stacks' voxel size, else their cell size, else the mesh voxel.
            voxel = kw.get("voxel_size") or kw.get("cell_size") or inputs["mesh_voxel"]
            terrain = _mesh_level_set(inputs["mesh"], voxel, kw["half_width"], inputs["level_set"])
        bake = {k: kw.pop(k) for k in list(kw) if k in rockvdb.Stacks.BAKE_ROWS}
        stacks = rockvdb.Stacks(terrain, **kw)
    grids = stacks.bake("all", **bake)
    return list(grids.values())


# The tile sets this session made, by their rows (JSON): a pile whose tile rows did not change
# (the redo panel's edits of the pile's own rows, Regenerate, a second pile) takes the same
# file instead of making it again (2-3 s at the defaults). A tile set is a pure function of its
# rows, so the bits are the same; each pile still names a file of its own (a hard link).
_tile_sets = {}


def _tile_set(rows, path):
    key = json.dumps(rows, sort_keys=True)
    made = _tile_sets.get(key)
    if made and os.path.isfile(made):
        try:
            os.link(made, path)
            return
        except OSError:
            pass
    rockvdb.rock_tiles(path=path, **rows)
    _tile_sets[key] = path


def _run_rock_pile(kw, inputs):
    _tile_set(kw["tiles_"], inputs["tiles"])
    if not inputs.get("instances"):
        return list(rockvdb.rock_pile(inputs["tiles"], inputs["support"], **kw[""]))
    stats = {}
    grids = list(rockvdb.rock_pile(inputs["tiles"], inputs["support"], stats=stats, **kw[""]))
    return grids, {"instances": _pile_instances(inputs["tiles"], stats,
                                                grids[0].transform.voxelSize()[0])}


def _pile_instances(tiles_path, stats, dx):
    """The pile's rocks as instances: each library rock the pile uses, meshed in its canonical
    frame, and per instance that rock moved by its shift (no rotation: a pile places its tile
    set's rocks as they are). rock_id: the instance's index, as the pile's grid holds it."""
    import pyopenvdb
    from rockvdb import _rockvdb
    used = sorted(set(stats["rocks"]))
    where = {r: i for i, r in enumerate(used)}
    meshes = _rockvdb.rock_meshes(pyopenvdb.read(tiles_path, "rho"), used)
    n = len(stats["rocks"])
    return {"rocks": [{"points": p, "triangles": t} for p, t in meshes],
            "index": [where[r] for r in stats["rocks"]],
            "positions": np.asarray(stats["shifts"], np.float64) * dx,
            "orients": np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)), "pscale": np.ones(n, np.float32),
            "rock_id": np.arange(n)}


def _run_detail(kw, inputs):
    grids = inputs["grids"]
    surface = next(g for g in grids if g.name == "surface")
    # The input's id grids are carried onto the new band, as vdb_detail carries a file's.
    ids = [g for g in grids if g.name in results.ID_GRIDS]
    if not ids:
        return [rockvdb.detail(surface, **kw[""])]
    return list(rockvdb.detail(surface, ids=ids, **kw[""]))


# ---------------------------------------------------------------------------------------------
# Each result's largest extent (m), for the Preview quality's rule.

def _extent_rock(stage, kw, inputs):
    """A rock (and each rock of a scatter: they are what the voxels resolve): its size."""
    return 2.0 * max(stage.default(kw, "size"))


def _extent_tile(stage, kw, inputs):
    return stage.default(kw, "tile_size") * max(stage.default(kw, "periods"))


def _extent_mesh(stage, kw, inputs):
    """The input mesh's (a terrain's) largest extent; a heightfield's."""
    if "mesh" in inputs:
        pts = inputs["mesh"][0]
        return float((pts.max(0) - pts.min(0)).max())
    if "heights" in inputs:
        rows, cols = inputs["heights"].shape
        return max(rows, cols) * stage.default(kw, "cell_size")
    return None


def _instances_property(what):
    return bpy.props.BoolProperty(
        name="As instances", description=f"Also make the rocks Blender instances (collection "
        f"instancing): {what}. The level set is kept (export, ids) and its mesh hidden")


STAGES = [
    Stage("fractal_rock", "Fractal Rock", "MESH_ICOSPHERE",
          "Add a fractal rock: an icosahedron refined by random midpoint displacement.",
          [("fractal_rock", rockvdb.fractal_rock, "")], _gather_none, _run_fractal_rock,
          extent=_extent_rock),
    Stage("fractal_scatter", "Fractal Scatter", "PARTICLES",
          "Scatter fractal rocks on the active mesh, or on the ground plane when none is selected.",
          [("fractal_scatter", rockvdb.fractal_scatter, "")], _gather_ground,
          _run_fractal_scatter, extent=_extent_rock,
          extra={"instances": _instances_property(
              "each its own mesh in its own frame, instanced on points at their positions and "
              "orientations (P, orient, pscale)")}),
    Stage("block_tile", "Block Tile", "MOD_EXPLODE",
          "Add a tile of fractured rock blocks that repeats seamlessly.",
          [("block_tile", rockvdb.block_tile, "")], _gather_tile, _run_block_tile,
          extent=_extent_tile),
    Stage("rock_pile", "Rock Pile", "OUTLINER_OB_POINTCLOUD",
          "Fill the active closed mesh with a pile of packed rocks.",
          [("rock_tiles", rockvdb.rock_tiles, "tiles_"), ("rock_pile", rockvdb.rock_pile, "")],
          _gather_support, _run_rock_pile,
          extra={"instances": _instances_property(
              "the tile set's rocks the pile uses, each meshed in its own frame, instanced on "
              "one point per placed rock")}),
    Stage("amplify", "Amplify Terrain", "MOD_OCEAN",
          "Cover the steep parts of the active terrain mesh with the blocks of the scene's Block Tiles.",
          [("amplify", rockvdb.amplify, "")], _gather_amplify, _run_amplify, extent=_extent_mesh,
          extra={
              "tiles": bpy.props.StringProperty(
                  name="Tiles", description="Block Tile results (object names) or .tile files, "
                  "comma-separated; strata name them by object name or file stem. Empty: every "
                  "Block Tile result in the scene"),
              "terrain_as": bpy.props.EnumProperty(
                  name="Terrain as", description="How the active mesh becomes the terrain",
                  items=[("LEVEL_SET", "Level set", "The mesh (an open sheet closed downward by "
                          "base depth) as a level set at the bake's voxel size: overhangs kept"),
                         ("HEIGHTFIELD", "Heightfield", "Its heights sampled every cell size "
                          "from the world origin (the mesh at x, y >= 0): the exact distance "
                          "to the heightfield's triangles")])}),
    Stage("stacks", "Material Stacks", "MOD_DATA_TRANSFER",
          "Turn the active terrain mesh into layers of sand, bedrock and rocks, settled at their repose angles.",
          [("arches", rockvdb.Stacks, "")], _gather_stacks, _run_stacks,
          positional=("terrain",),
          extra={
              "scene": bpy.props.StringProperty(
                  name="Scene file", subtype="FILE_PATH",
                  description="A vdb_arches scene (.json): its terrain, parameters and edits; "
                  "properties set here override its keys. Empty: the Terrain row, else the "
                  "active mesh"),
              "mesh_voxel": bpy.props.FloatProperty(
                  name="Mesh voxel", unit="LENGTH", min=1e-4, default=0.25,
                  description="Voxel size at which the active mesh becomes the terrain level set "
                  "when neither voxel size nor cell size is set")}),
    Stage("detail", "Detail", "MOD_DISPLACE",
          "Add weathering and ridges to the surface of the active rockvdb result.",
          [("detail", rockvdb.detail, "")], _gather_result, _run_detail),
]
