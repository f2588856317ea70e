# SPDX-License-Identifier: Apache-2.0
"""A stage's grids as Blender objects.

A result is one mesh object, the object an artist handles. Its mesh is real mesh data, made
on the worker thread (OpenVDB's volumeToMesh, with the ids per vertex as vdb_mesh --ids) and
handed to Blender as arrays, so it is saved in the .blend and shows after reopening without
anything evaluated on the UI thread. Its attributes are the id grids per vertex, 'material',
'block_id', 'rock_id' (each vertex the id of the nearest surface voxel), and for material
stacks the weight_* grids (trilinear); its material tints by them (Attribute node: Cycles and
Eevee), or for material stacks textures the ground by its weights (arches §6: triplanar noise
per material, Lp weights p = 8, blended by the weights).

The grids themselves (for Export .vdb, Detail and the ids) live in a cache .vdb in the cache
folder: //rockvdb_cache/ beside the .blend, or Blender's temporary folder for an unsaved file;
on save they move beside the .blend (save_post), so a saved file keeps them, also when the
.blend and its rockvdb_cache folder move together. A result names its files relative to the
cache folder.

The mesh object carries the custom properties rockvdb_stage, rockvdb_version,
rockvdb_params (the stage's parameters, as each grid's rockvdb:params holds them),
rockvdb_operator (the operator's properties, for Regenerate) and rockvdb_cache (its grids'
file in the cache folder)."""
import json
import os
import shutil
import sys
import uuid

import bpy
import numpy as np

import rockvdb
from rockvdb import _rockvdb

ID_GRIDS = ("material", "block_id", "rock_id")
# arches §6: the share of each ground material's visible faces (vdb_arches' weight_<name>)
WEIGHT_PREFIX = "weight_"
# Each material's noise scale (1/m) in the default material; its colour is rockvdb's
# (material_colour: the one vdb_preview --texture paints).
NOISE_SCALES = {"sand": 40.0, "bedrock": 4.0, "rocks": 10.0}
# The custom properties that name files in the cache folder (relative to it).
FILE_PROPS = ("rockvdb_cache", "rockvdb_tile")


def _temp_cache_dir():
    return os.path.join(bpy.app.tempdir or "/tmp", "rockvdb_cache")


def cache_dir():
    if bpy.data.filepath:
        return bpy.path.abspath("//rockvdb_cache")
    return _temp_cache_dir()


def safe_name(name):
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


def unique_name(label):
    """The name Blender gives a new object called @a label: itself, else label.001, ..."""
    name, n = label, 0
    while name in bpy.data.objects:
        n += 1
        name = f"{label}.{n:03d}"
    return name


def cache_path(name):
    d = cache_dir()
    os.makedirs(d, exist_ok=True)
    return os.path.join(d, f"{safe_name(name)}_{uuid.uuid4().hex[:8]}.vdb")


def cache_file(name):
    """A file a result names (relative to the cache folder) as a path; an absolute name (an
    older result's) is itself."""
    return name if os.path.isabs(name) else os.path.join(cache_dir(), name)


def cache_name(path):
    """@a path as a result names it: relative to the cache folder when inside it."""
    rel = os.path.relpath(path, cache_dir())
    return path if rel.startswith("..") else rel


def missing_cache(obj):
    """The result's grids' file when it is missing (else None)."""
    name = obj.get("rockvdb_cache")
    if not name:
        return None
    path = cache_file(name)
    return None if os.path.isfile(path) else path


def _results():
    return [o for o in bpy.data.objects if o.get("rockvdb_stage")]


_saved_from = {}


def save_pre(*_):
    """Where the caches are before the save (bpy.data.filepath is still the old one)."""
    _saved_from["dir"] = cache_dir()


def save_post(*_):
    """The caches follow the .blend: an unsaved file's move from Blender's temporary folder to
    //rockvdb_cache/ beside it; a file saved under a new folder copies its results' files
    there. Results name their files relative to the cache folder, so nothing else changes."""
    old, new = _saved_from.pop("dir", None), cache_dir()
    if not old or os.path.realpath(old) == os.path.realpath(new) or not os.path.isdir(old):
        return
    names = {o[k] for o in _results() for k in FILE_PROPS if o.get(k) and not os.path.isabs(o[k])}
    temporary = os.path.realpath(old) == os.path.realpath(_temp_cache_dir())
    for name in sorted(names):
        src, dst = os.path.join(old, name), os.path.join(new, name)
        if not os.path.exists(src) or os.path.exists(dst):
            continue
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        try:
            (shutil.move if temporary else shutil.copy2)(src, dst)
        except OSError as e:
            print(f"rockvdb: could not keep {src} beside the .blend ({e.strerror})", file=sys.stderr)
    if temporary:
        # The rest of the session's cache (the inputs the results' provenance names: meshes
        # as level sets, supports, tile sets) follows too, so CLI replays find them.
        for entry in os.listdir(old):
            src, dst = os.path.join(old, entry), os.path.join(new, entry)
            if not os.path.exists(dst):
                try:
                    shutil.move(src, dst)
                except OSError:
                    pass


def load_post(*_):
    """A result whose grids' cache is gone (deleted, or a .blend moved without its
    rockvdb_cache folder): one line naming it; its mesh still shows, the sidebar offers
    Regenerate."""
    for obj in _results():
        path = missing_cache(obj)
        if path:
            print(f"rockvdb: '{obj.name}': its grids' cache {path} is missing (the mesh is "
                  "kept; Regenerate makes the grids again)", file=sys.stderr)


def _link(obj, collection):
    collection.objects.link(obj)
    return obj


def _node_group(name):
    """A geometry-nodes group with one geometry in and out: (group, nodes, links, its input
    node, its output node)."""
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    ng.inputs.new("NodeSocketGeometry", "Geometry")
    ng.outputs.new("NodeSocketGeometry", "Geometry")
    return ng, ng.nodes, ng.links, ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")


def _material(name, attribute, instancer=False):
    """Rock grey tinted by an id attribute: each id its own hue (White Noise of the id); the
    mesh's own attribute, or with @a instancer the instancing point's."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    N, L = mat.node_tree.nodes, mat.node_tree.links
    bsdf = N.get("Principled BSDF")
    bsdf.inputs["Roughness"].default_value = 0.85
    if attribute is None:
        bsdf.inputs["Base Color"].default_value = (0.30, 0.28, 0.26, 1.0)
        return mat
    attr = N.new("ShaderNodeAttribute")
    attr.attribute_type = "INSTANCER" if instancer else "GEOMETRY"
    attr.attribute_name = attribute
    noise = N.new("ShaderNodeTexWhiteNoise")
    noise.noise_dimensions = "1D"
    L.new(attr.outputs["Fac"], noise.inputs["W"])
    mix = N.new("ShaderNodeMixRGB")
    mix.inputs["Fac"].default_value = 0.5
    mix.inputs["Color1"].default_value = (0.30, 0.28, 0.26, 1.0)
    L.new(noise.outputs["Color"], mix.inputs["Color2"])
    L.new(mix.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def _textured_material(name, weights):
    """arches §6: every ground material's texture mapped triplanarly (three 2D noise patterns
    on the axis planes, Lp weights |n_i|^8 / Σ|n_j|^8 of the normal), blended by the weight
    attributes (per vertex, as the paper): Σ w_m T_m / Σ w_m."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    N, L = mat.node_tree.nodes, mat.node_tree.links
    bsdf = N.get("Principled BSDF")
    bsdf.inputs["Roughness"].default_value = 0.9

    def math(op, a, b=None, c=None):
        m = N.new("ShaderNodeMath")
        m.operation = op
        for k, v in enumerate((a, b, c)):
            if v is None:
                continue
            if isinstance(v, (int, float)):
                m.inputs[k].default_value = v
            else:
                L.new(v, m.inputs[k])
        return m.outputs[0]

    geo = N.new("ShaderNodeNewGeometry")
    pos, nrm = N.new("ShaderNodeSeparateXYZ"), N.new("ShaderNodeSeparateXYZ")
    L.new(geo.outputs["Position"], pos.inputs[0])
    L.new(geo.outputs["Normal"], nrm.inputs[0])
    powered = [math("POWER", math("ABSOLUTE", nrm.outputs[k]), 8.0) for k in range(3)]
    total = math("ADD", math("ADD", powered[0], powered[1]), powered[2])
    lp = [math("DIVIDE", powered[k], math("MAXIMUM", total, 1e-12)) for k in range(3)]
    projections = []  # (u, v) of the projection along x, y, z: (y, z), (x, z), (x, y)
    for u, v in ((1, 2), (0, 2), (0, 1)):
        c = N.new("ShaderNodeCombineXYZ")
        L.new(pos.outputs[u], c.inputs[0])
        L.new(pos.outputs[v], c.inputs[1])
        projections.append(c.outputs[0])
    colour_sum, weight_sum = None, None
    for attr in weights:
        kind = attr[len(WEIGHT_PREFIX):]
        rgb, scale = rockvdb.material_colour(kind), NOISE_SCALES.get(kind, 6.0)
        shade = None
        for k in range(3):
            tex = N.new("ShaderNodeTexNoise")
            tex.noise_dimensions = "2D"
            tex.inputs["Scale"].default_value = scale
            L.new(projections[k], tex.inputs["Vector"])
            term = math("MULTIPLY", lp[k], tex.outputs["Fac"])
            shade = term if shade is None else math("ADD", shade, term)
        w = N.new("ShaderNodeAttribute")
        w.attribute_name = attr
        weight = math("MAXIMUM", w.outputs["Fac"], 0.0)
        coloured = N.new("ShaderNodeVectorMath")
        coloured.operation = "SCALE"
        coloured.inputs[0].default_value = rgb
        L.new(math("MULTIPLY", math("MULTIPLY_ADD", shade, 0.8, 0.6), weight), coloured.inputs["Scale"])
        if colour_sum is None:
            colour_sum, weight_sum = coloured.outputs[0], weight
        else:
            add = N.new("ShaderNodeVectorMath")
            add.operation = "ADD"
            L.new(colour_sum, add.inputs[0])
            L.new(coloured.outputs[0], add.inputs[1])
            colour_sum, weight_sum = add.outputs[0], math("ADD", weight_sum, weight)
    final = N.new("ShaderNodeVectorMath")
    final.operation = "SCALE"
    L.new(colour_sum, final.inputs[0])
    L.new(math("DIVIDE", 1.0, math("MAXIMUM", weight_sum, 1e-6)), final.inputs["Scale"])
    L.new(final.outputs[0], bsdf.inputs["Base Color"])
    return mat


def mesh_adaptivity(quality):
    """The mesh density of a quality: Final meshes as vdb_mesh does by default (its table),
    Preview at the preview rule's adaptivity (core/Schema.h, beside the tables)."""
    if quality == "PREVIEW":
        return float(_rockvdb.PREVIEW_ADAPTIVITY)
    rows = json.loads(_rockvdb.schema("mesh"))["params"]
    return float(next(r["default"] for r in rows if r["name"] == "adaptivity"))


def stage_params(grids):
    """The stage's parameters as the grids' provenance holds them (JSON text), and version."""
    for g in grids:
        if g.name == "surface" and "rockvdb:params" in g.metadata:
            return g["rockvdb:params"], g["rockvdb:version"], g["rockvdb:generator"]
    return "{}", rockvdb.__version__, ""


def prepare(grids, path, adaptivity, scale=1.0):
    """What build() needs that takes no bpy, for the worker thread: the grids written to the
    cache file @a path, and their mesh as Blender's arrays (points in scene units: metres /
    @a scale, Blender's Unit Scale), with the ids and weights per vertex."""
    rockvdb.write(path, grids)
    surface = next(g for g in grids if g.name == "surface")
    ids = [g for g in grids if g.name in ID_GRIDS]
    weights = sorted((g for g in grids if g.name.startswith(WEIGHT_PREFIX)), key=lambda g: g.name)
    mesh = _rockvdb.mesh_arrays(surface, adaptivity, ids, weights)
    if scale != 1.0:
        mesh["points"] = (mesh["points"] / scale).astype(np.float32)
    return {"path": path, "grids": grids, "mesh": mesh, "adaptivity": adaptivity}


def mesh_steps(name, mesh):
    """Make a Blender mesh from prepare()'s arrays, a step at a time: yields None after each
    costly copy (the modal operator runs one step per timer tick, so the UI keeps answering),
    then the finished Mesh. Closing the generator early removes the half-made mesh."""
    me = bpy.data.meshes.new(name)
    try:
        pts, loops = mesh["points"], mesh["loops"]
        me.vertices.add(len(pts))
        me.vertices.foreach_set("co", np.ascontiguousarray(pts, np.float32).ravel())
        yield None
        me.loops.add(len(loops))
        me.loops.foreach_set("vertex_index", loops)
        yield None
        me.polygons.add(len(mesh["starts"]))
        me.polygons.foreach_set("loop_start", mesh["starts"])
        me.polygons.foreach_set("loop_total", mesh["totals"])
        yield None
        me.polygons.foreach_set("use_smooth", np.ones(len(mesh["starts"]), bool))
        me.update(calc_edges=True)
        yield None
        for attr, values in list(mesh["ids"].items()) + list(mesh["weights"].items()):
            a = me.attributes.new(attr, "FLOAT", "POINT")
            a.data.foreach_set("value", values)
    except BaseException:  # an error, or the generator closed (Esc) before the end
        bpy.data.meshes.remove(me)
        raise
    yield me


def build_steps(context, stage, label, prepared, operator_props, target=None):
    """Objects for the prepare()d grids (the new result, or @a target's replaced in place), a
    step at a time (see mesh_steps); the last value is the result's mesh object."""
    grids, mesh = prepared["grids"], prepared["mesh"]
    params, version, generator = stage_params(grids)
    collection = context.collection or context.scene.collection
    replace = target is not None and target.get("rockvdb_stage") == stage
    name = target.name if replace else unique_name(label)
    me = None
    for me in mesh_steps(name, mesh):
        if me is None:
            yield None
    attrs = [a for a in ID_GRIDS if a in mesh["ids"]]
    weights = sorted(mesh["weights"])
    if replace:
        obj = target
        old_mesh, old_cache = obj.data, obj.get("rockvdb_cache")
        obj.data = me
        if old_mesh.users == 0:
            bpy.data.meshes.remove(old_mesh)
        if old_cache:
            old = cache_file(old_cache)
            if old.startswith(cache_dir()) and os.path.exists(old) and old != prepared["path"]:
                os.remove(old)
    else:
        obj = _link(bpy.data.objects.new(label, me), collection)
        for o in context.view_layer.objects:
            if o is not None:  # (a base whose object was just removed, before Blender resyncs)
                o.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
    _set_material(obj, attrs, weights)
    _set_instances(obj, collection, prepared.get("instances"), prepared.get("scale", 1.0))
    obj["rockvdb_stage"] = stage
    obj["rockvdb_generator"] = generator
    obj["rockvdb_version"] = version
    obj["rockvdb_params"] = params
    obj["rockvdb_operator"] = json.dumps(operator_props)
    obj["rockvdb_cache"] = cache_name(prepared["path"])
    obj["rockvdb_ids"] = attrs + weights
    # How the mesh was made: vdb_mesh --adaptivity of the cache file gives the same mesh.
    obj["rockvdb_mesh_adaptivity"] = prepared.get("adaptivity", 0.0)
    yield obj


def build(context, stage, label, prepared, operator_props, target=None):
    """build_steps() at once; returns the mesh object."""
    for obj in build_steps(context, stage, label, prepared, operator_props, target):
        pass
    return obj


def _set_material(obj, attrs, weights):
    """The tinting material for the id attributes @a attrs, or for material stacks' ground
    the textured one of its @a weights (§6)."""
    mat = _textured_material(obj.name, weights) if weights else _material(obj.name, attrs[0] if attrs else None)
    if obj.data.materials:
        obj.data.materials[0] = mat
    else:
        obj.data.materials.append(mat)


def grids_of(obj):
    """The grids of a rockvdb result object (read from its cache .vdb), as pyopenvdb grids."""
    if not obj.get("rockvdb_stage"):
        raise ValueError(f"'{obj.name}' is not a rockvdb result")
    path = missing_cache(obj)
    if path:
        raise ValueError(f"'{obj.name}': its grids' cache {path} is missing: Regenerate makes "
                         "it again")
    import pyopenvdb
    return pyopenvdb.readAll(cache_file(obj["rockvdb_cache"]))[0]


def _instancer_tree(name, rocks):
    """Geometry nodes on the instance points: Instance on Points of the rocks collection's
    children, picked by the point's 'rock', rotated by 'rotation' (Euler XYZ), scaled by
    'pscale'."""
    ng, N, L, gin, gout = _node_group(name)
    info = N.new("GeometryNodeCollectionInfo")
    info.inputs["Collection"].default_value = rocks
    info.inputs["Separate Children"].default_value = True
    info.inputs["Reset Children"].default_value = True
    inst = N.new("GeometryNodeInstanceOnPoints")
    L.new(gin.outputs[0], inst.inputs["Points"])
    L.new(info.outputs[0], inst.inputs["Instance"])
    inst.inputs["Pick Instance"].default_value = True

    def named(attr, kind, socket):
        n = N.new("GeometryNodeInputNamedAttribute")
        n.data_type = kind
        n.inputs["Name"].default_value = attr
        out = next(o for o in n.outputs if o.enabled)
        L.new(out, inst.inputs[socket])
    named("rock", "INT", "Instance Index")
    named("rotation", "FLOAT_VECTOR", "Rotation")
    named("pscale", "FLOAT", "Scale")
    L.new(inst.outputs[0], gout.inputs[0])
    return ng


def _set_instances(obj, collection, instances, scale=1.0):
    """The result's instances (made again on Regenerate): a collection '<name> rocks' of one
    mesh per distinct rock (not linked to the scene: only instanced) and a child
    '<name> instances' of points instancing them, with attributes 'rock' (which mesh),
    'rotation' (Euler XYZ), 'pscale' and 'rock_id' (the level set's id of that instance, which
    the rocks' material reads from the instancer). The level set's own mesh is hidden while
    instances show.
    instances: {"rocks": [{"points", "triangles"}] in each rock's own frame, "index": the rock
    of each instance (default: instance i is rock i), "positions", "orients" (quaternions x,
    y, z, w), "pscale", "rock_id"} per instance, lengths in metres (divided by @a scale, the
    Unit Scale, here)."""
    from mathutils import Quaternion
    old = obj.get("rockvdb_instances")
    if old is not None:
        rocks = old.modifiers[0].node_group.nodes["Collection Info"].inputs["Collection"].default_value
        for o in list(rocks.objects):
            bpy.data.objects.remove(o)
        bpy.data.collections.remove(rocks)
        bpy.data.objects.remove(old)
        del obj["rockvdb_instances"]
    # With instances the level set's own mesh is drawn as its bounds (still selectable) and
    # not rendered: the instances show the rocks.
    obj.display_type = "TEXTURED" if instances is None else "BOUNDS"
    obj.hide_render = instances is not None
    if instances is None:
        return
    rocks = bpy.data.collections.new(obj.name + " rocks")
    mat = _material(obj.name + " instances", "rock_id", instancer=True)
    for i, r in enumerate(instances["rocks"]):
        me = bpy.data.meshes.new(f"{obj.name} rock {i:04d}")
        me.from_pydata((np.asarray(r["points"], np.float64) / scale).tolist(), [],
                       r["triangles"].tolist())
        me.polygons.foreach_set("use_smooth", [True] * len(me.polygons))
        me.materials.append(mat)
        rocks.objects.link(bpy.data.objects.new(me.name, me))
    n = len(instances["positions"])
    index = np.asarray(instances.get("index", np.arange(n)), np.int32)
    pm = bpy.data.meshes.new(obj.name + " instances")
    pm.vertices.add(n)
    pm.vertices.foreach_set("co", np.ascontiguousarray(np.asarray(instances["positions"]) / scale,
                                                       np.float32).ravel())
    rot = [Quaternion((q[3], q[0], q[1], q[2])).to_euler("XYZ") for q in instances["orients"]]
    for attr, kind, values in (("rock", "INT", index),
                               ("rotation", "FLOAT_VECTOR",
                                np.array([tuple(e) for e in rot], np.float32).ravel()),
                               ("pscale", "FLOAT", np.asarray(instances["pscale"], np.float32)),
                               ("rock_id", "FLOAT", np.asarray(instances["rock_id"], np.float32))):
        a = pm.attributes.new(attr, kind, "POINT")
        a.data.foreach_set("vector" if kind == "FLOAT_VECTOR" else "value", values)
    inst = _link(bpy.data.objects.new(obj.name + " instances", pm), collection)
    inst.parent = obj
    inst.hide_select = True
    mod = inst.modifiers.new("rockvdb instances", "NODES")
    mod.node_group = _instancer_tree(obj.name + " instances", rocks)
    obj["rockvdb_instances"] = inst
