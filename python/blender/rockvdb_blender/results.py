# SPDX-License-Identifier: Apache-2.0
"""A stage's grids as Blender objects.

One result is three objects, the first the one an artist handles:
  <name>         a mesh object: a Volume to Mesh modifier on the grids' 'surface' (threshold
                 0, vdb_mesh's adaptivity), then a geometry-nodes modifier that copies the id
                 grids onto the mesh's points as attributes 'material', 'block_id', 'rock_id'
                 (each vertex takes the id of the nearest surface voxel), and a material that
                 tints by them (Attribute node: Cycles and Eevee) — or, for material stacks, their
                 weight_* grids too, and a material that textures the ground by them (arches §6:
                 triplanar noise per material, Lp weights p = 8, blended by the weights);
  <name> grids   the Volume object holding the grids, read from a cache .vdb next to the .blend
                 (//rockvdb_cache/, or Blender's temporary folder for an unsaved file), hidden;
  <name> ids     the id grids' surface voxels as points with those attributes, hidden.
The mesh object carries the custom properties rockvdb_stage, rockvdb_version,
rockvdb_params (the stage's parameters, as each grid's rockvdb:params holds them) and
rockvdb_operator (the operator's properties, for Regenerate)."""
import json
import os
import uuid

import bpy
import numpy as np

import rockvdb
from rockvdb import _rockvdb

ID_GRIDS = ("material", "block_id", "rock_id")
# arches §6: the share of each ground material's visible faces (vdb_arches' weight_<name>)
WEIGHT_PREFIX = "weight_"
# Colour (linear) and 2D pattern scale (1/m) of each known material's texture
# Each material's noise scale (1/m) in the default material; its colour is rockvdb's
# (material_colour: the one vdb_preview --texture paints).
NOISE_SCALES = {"sand": 40.0, "bedrock": 4.0, "rocks": 10.0}


def cache_dir():
    if bpy.data.filepath:
        return bpy.path.abspath("//rockvdb_cache")
    return os.path.join(bpy.app.tempdir or "/tmp", "rockvdb_cache")


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


def mesh_adaptivity():
    """vdb_mesh's default adaptivity (its table): the meshes the add-on and vdb_mesh make
    agree."""
    rows = json.loads(_rockvdb.schema("mesh"))["params"]
    return float(next(r["default"] for r in rows if r["name"] == "adaptivity"))


def _link(obj, collection):
    collection.objects.link(obj)
    return obj


def _id_points(grids):
    """The id grids' values at the surface voxels (|phi| <= half a voxel: about one voxel per
    surface column, enough for the nearest-point look-up): (points N x 3, {name: values N})."""
    surface = next(g for g in grids if g.name == "surface")
    ids = [g for g in grids if g.name in ID_GRIDS or g.name.startswith(WEIGHT_PREFIX)]
    if not ids:
        return np.zeros((0, 3), np.float32), {}
    pts, values = _rockvdb.surface_ids(surface, ids, 0.5)
    return pts, {g.name: values[:, i] for i, g in enumerate(ids)}


def _node_group(name):
    """A geometry-nodes group with one geometry in and out: (group, nodes, links, its input
    node, its output node)."""
    ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
    ng.inputs.new("NodeSocketGeometry", "Geometry")
    ng.outputs.new("NodeSocketGeometry", "Geometry")
    return ng, ng.nodes, ng.links, ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")


def _ids_tree(name, points_obj, attributes):
    """Geometry nodes: each point of the mesh takes, for every id attribute, the value of the
    nearest point of @a points_obj."""
    ng, N, L, gin, gout = _node_group(name)
    info = N.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = points_obj
    info.transform_space = "RELATIVE"
    nearest = N.new("GeometryNodeSampleNearest")
    nearest.domain = "POINT"
    L.new(info.outputs["Geometry"], nearest.inputs["Geometry"])
    L.new(N.new("GeometryNodeInputPosition").outputs["Position"], nearest.inputs["Sample Position"])
    geometry = gin.outputs[0]
    for attr in attributes:
        named = N.new("GeometryNodeInputNamedAttribute")
        named.data_type = "FLOAT"
        named.inputs["Name"].default_value = attr
        sample = N.new("GeometryNodeSampleIndex")
        sample.data_type, sample.domain = "FLOAT", "POINT"
        L.new(info.outputs["Geometry"], sample.inputs["Geometry"])
        L.new(named.outputs[1], sample.inputs[1])           # the float "Attribute" / "Value"
        L.new(nearest.outputs["Index"], sample.inputs["Index"])
        store = N.new("GeometryNodeStoreNamedAttribute")
        store.data_type, store.domain = "FLOAT", "POINT"
        store.inputs["Name"].default_value = attr
        L.new(geometry, store.inputs["Geometry"])
        L.new(sample.outputs[0], store.inputs[3])            # the float "Value"
        geometry = store.outputs[0]
    L.new(geometry, gout.inputs[0])
    return ng


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


def _points_mesh(name, pts, values):
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(pts))
    me.vertices.foreach_set("co", np.ascontiguousarray(pts, np.float32).ravel())
    for attr, v in values.items():
        a = me.attributes.new(attr, "FLOAT", "POINT")
        a.data.foreach_set("value", np.ascontiguousarray(v, np.float32))
    return me


def stage_params(grids):
    """The stage's parameters as the grids' provenance holds them (JSON text), and version."""
    for g in grids:
        if g.name == "surface" and "rockvdb:params" in g.metadata:
            return g["rockvdb:params"], g["rockvdb:version"], g["rockvdb:generator"]
    return "{}", rockvdb.__version__, ""


def prepare(grids, path):
    """What build() needs that takes no bpy, for the worker thread: the grids written to the
    cache file @a path, and the id points."""
    rockvdb.write(path, grids)
    return {"path": path, "grids": grids, "ids": _id_points(grids)}


def build(context, stage, label, prepared, operator_props, target=None):
    """Objects for the prepare()d grids (the new result, or @a target's replaced in place).
    Returns the mesh object."""
    path, grids = prepared["path"], prepared["grids"]
    pts, values = prepared["ids"]
    params, version, generator = stage_params(grids)
    collection = context.collection or context.scene.collection

    if target is not None and target.get("rockvdb_stage") == stage:
        obj = target
        vol_obj = obj.get("rockvdb_volume")
        pts_obj = obj.get("rockvdb_points")
        old = bpy.path.abspath(vol_obj.data.filepath)
        vol_obj.data.filepath = path
        vol_obj.data.grids.load()
        old_mesh = pts_obj.data
        pts_obj.data = _points_mesh(obj.name + " ids", pts, values)
        bpy.data.meshes.remove(old_mesh)
        if old.startswith(cache_dir()) and os.path.exists(old) and old != path:
            os.remove(old)
        if set(values) != set(obj.get("rockvdb_ids", [])):
            _set_ids(obj, pts_obj, values)
    else:
        vol = bpy.data.volumes.new(label + " grids")
        vol.filepath = path
        vol_obj = _link(bpy.data.objects.new(label + " grids", vol), collection)
        obj = _link(bpy.data.objects.new(label, bpy.data.meshes.new(label)), collection)
        pts_obj = _link(bpy.data.objects.new(label + " ids", _points_mesh(label + " ids", pts, values)),
                        collection)
        for child in (vol_obj, pts_obj):
            child.parent = obj
            child.hide_viewport = child.hide_render = True
            child.hide_select = True
        mod = obj.modifiers.new("rockvdb surface", "VOLUME_TO_MESH")
        mod.object = vol_obj
        mod.grid_name = "surface"
        mod.threshold = 0.0
        mod.resolution_mode = "GRID"
        mod.adaptivity = mesh_adaptivity()
        mod.use_smooth_shade = True
        obj["rockvdb_volume"] = vol_obj
        obj["rockvdb_points"] = pts_obj
        _set_ids(obj, pts_obj, values)
        for o in context.view_layer.objects:
            o.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
    _set_instances(obj, collection, prepared.get("instances"))
    obj["rockvdb_stage"] = stage
    obj["rockvdb_generator"] = generator
    obj["rockvdb_version"] = version
    obj["rockvdb_params"] = params
    obj["rockvdb_operator"] = json.dumps(operator_props)
    obj["rockvdb_cache"] = path
    return obj


def _set_ids(obj, pts_obj, values):
    """The ids modifier and the tinting material for the id attributes in @a values."""
    attrs = [a for a in ID_GRIDS if a in values]
    weights = sorted(a for a in values if a.startswith(WEIGHT_PREFIX))
    old = obj.modifiers.get("rockvdb ids")
    if old is not None:
        obj.modifiers.remove(old)
    if attrs or weights:
        mod = obj.modifiers.new("rockvdb ids", "NODES")
        mod.node_group = _ids_tree(obj.name + " ids", pts_obj, attrs + weights)
    obj["rockvdb_ids"] = attrs + weights
    # Material stacks' ground: textured by its weights (§6); anything else tinted by its ids.
    mat = _textured_material(obj.name, weights) if weights else _material(obj.name, attrs[0] if attrs else None)
    if obj.data.materials:
        obj.data.materials[0] = mat
    else:
        obj.data.materials.append(mat)


def grids_of(obj):
    """The grids of a rockvdb result object (read from its cache .vdb), as pyopenvdb grids."""
    vol_obj = obj.get("rockvdb_volume")
    if vol_obj is None:
        raise ValueError(f"'{obj.name}' is not a rockvdb result")
    import pyopenvdb
    return pyopenvdb.readAll(bpy.path.abspath(vol_obj.data.filepath))[0]


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


def _set_instances(obj, collection, instances):
    """The result's instances (made again on Regenerate): a collection '<name> rocks' of one
    mesh per distinct rock (not linked to the scene: only instanced) and a child
    '<name> instances' of points instancing them, with attributes 'rock' (which mesh),
    'rotation' (Euler XYZ), 'pscale' and 'rock_id' (the level set's id of that instance, which
    the rocks' material reads from the instancer). The level set's own mesh is hidden while
    instances show.
    instances: {"rocks": [{"points", "triangles"}] in each rock's own frame, "index": the rock
    of each instance (default: instance i is rock i), "positions", "orients" (quaternions x,
    y, z, w), "pscale", "rock_id"} per instance."""
    from mathutils import Quaternion
    old = obj.get("rockvdb_instances")
    if old is not None:
        rocks = old.modifiers[0].node_group.nodes["Collection Info"].inputs["Collection"].default_value
        for o in list(rocks.objects):
            bpy.data.objects.remove(o)
        bpy.data.collections.remove(rocks)
        bpy.data.objects.remove(old)
        del obj["rockvdb_instances"]
    surface_mod = obj.modifiers.get("rockvdb surface")
    if surface_mod is not None:
        surface_mod.show_viewport = surface_mod.show_render = instances is None
    if instances is None:
        return
    rocks = bpy.data.collections.new(obj.name + " rocks")
    mat = _material(obj.name + " instances", "rock_id", instancer=True)
    for i, r in enumerate(instances["rocks"]):
        me = bpy.data.meshes.new(f"{obj.name} rock {i:04d}")
        me.from_pydata(r["points"].tolist(), [], r["triangles"].tolist())
        me.polygons.foreach_set("use_smooth", [True] * len(me.polygons))
        me.materials.append(mat)
        rocks.objects.link(bpy.data.objects.new(me.name, me))
    n = len(instances["positions"])
    index = np.asarray(instances.get("index", np.arange(n)), np.int32)
    pm = bpy.data.meshes.new(obj.name + " instances")
    pm.vertices.add(n)
    pm.vertices.foreach_set("co", np.ascontiguousarray(instances["positions"], np.float32).ravel())
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
