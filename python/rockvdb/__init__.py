# SPDX-License-Identifier: Apache-2.0
"""rockvdb: procedural rocks and rocky terrain as OpenVDB level sets.

Fields compose like fogleman/sdf and bake to pyopenvdb grids:

    import rockvdb
    f = rockvdb.sphere(1.0) | rockvdb.box((2, 0.5, 0.5), rounding=0.1)
    grid = f.warp(0.05, frequency=2, seed=3).bake(voxel_size=0.02)
    rockvdb.write("rock.vdb", [grid])

Units are metres, values are signed distances (negative inside), z is up; angles are degrees.
Grids are pyopenvdb.FloatGrid objects: level sets named 'surface', id grids ('block_id',
'rock_id', 'material') holding integer ids (background -1). Every grid carries provenance
(rockvdb:version, rockvdb:generator, rockvdb:params).

Fields: sphere, box, capsule, plane, polytope, expression -> Field (| & -, union, transform,
warp, tag, bake). Grids: heightfield, csg, detail, read, write, mesh, preview, provenance,
write_heightfield, read_image, read_rgb_exr, material_colour, coverage. Stages: block_tile / load_tile -> BlockTile (implicit-blocks
§4), amplify (§5), detail (§4.2 and the Gabor details paper), rock_tiles / rock_library /
rock_pile (aperiodic rock piles, arches §5), fractal_rock / fractal_scatter / fractal_carve
(fractal rocks), Stacks (material-stack terrain with overhangs, arches §3).

Errors: ValueError for bad values, TypeError (naming the parameter and the type expected) for
wrong types, IOError for files, KeyboardInterrupt when interrupted.

Off the main thread (a UI's worker), a Job reports progress and cancels: the calls a thread
makes inside ``with job:`` report ``job.progress`` (0..1) and ``job.phase``, and raise
KeyboardInterrupt soon after another thread calls ``job.cancel()``:

    job = rockvdb.Job()
    def work():
        with job:
            grids = rockvdb.fractal_rock(seed=3)
    threading.Thread(target=work).start()   # then poll job.progress, or job.cancel()
"""
import json as _json
import numbers as _numbers
import os as _os

import pyopenvdb  # noqa: F401  (registers the grid converters used by the extension)

from . import _rockvdb

__version__ = _rockvdb.__version__

Job = _rockvdb.Job
Job.__doc__ = ("A stage call watched from another thread: enter it (with job:) on the thread "
               "that calls; read progress (0..1) and phase, or cancel(), from any other.")

__all__ = ["BlockTile", "Field", "Job", "amplify", "asset", "asset_each", "asset_ids", "asset_instances", "block_tile", "box", "capsule", "coverage", "csg",
           "detail", "expression", "fractal_carve", "fractal_rock", "fractal_scatter", "heightfield", "load_tile", "mesh", "plane",
           "polytope", "preview",
           "material_colour", "provenance", "read", "read_image", "read_rgb_exr", "rock_library", "rock_pile", "rock_tiles",
           "sphere", "write", "write_heightfield", "__version__"]


# ---------------------------------------------------------------------------------------------
# Argument checks: a wrong type is a TypeError naming the function, the parameter and the type
# expected, never a binding's signature dump.

def _type_error(fn, name, expected, value):
    return TypeError(f"rockvdb.{fn}(): {name} must be {expected}, got {type(value).__name__}")


def _grid(value, name, fn):
    if not isinstance(value, pyopenvdb.FloatGrid):
        raise _type_error(fn, name, "a pyopenvdb.FloatGrid", value)
    return value


def _grids(values, name, fn):
    if isinstance(values, pyopenvdb.FloatGrid) or not hasattr(values, "__iter__"):
        raise _type_error(fn, name, "a list of pyopenvdb.FloatGrid", values)
    values = list(values)
    for i, g in enumerate(values):
        _grid(g, f"{name}[{i}]", fn)
    return values


def _float(value, name, fn):
    if isinstance(value, bool) or not isinstance(value, _numbers.Real):
        raise _type_error(fn, name, "a number", value)
    return float(value)


def _int(value, name, fn):
    if isinstance(value, bool) or not isinstance(value, _numbers.Integral):
        raise _type_error(fn, name, "an integer", value)
    return int(value)


def _bool(value, name, fn):
    if not isinstance(value, (bool, _numbers.Integral)):
        raise _type_error(fn, name, "a bool", value)
    return bool(value)


def _str(value, name, fn):
    if not isinstance(value, str):
        raise _type_error(fn, name, "a str", value)
    return value


def _path(value, name, fn):
    if not isinstance(value, (str, _os.PathLike)):
        raise _type_error(fn, name, "a path (str or os.PathLike)", value)
    return _os.fspath(value)


def _floats(value, n, name, fn):
    """A sequence of n numbers as a list of floats."""
    try:
        items = list(value)
    except TypeError:
        raise _type_error(fn, name, f"a sequence of {n} numbers", value) from None
    if len(items) != n or any(isinstance(v, bool) or not isinstance(v, _numbers.Real)
                              for v in items):
        raise TypeError(f"rockvdb.{fn}(): {name} must be a sequence of {n} numbers, got "
                        f"{value!r}")
    return [float(v) for v in items]


def _ints(value, n, name, fn):
    items = _floats(value, n, name, fn)
    if any(v != int(v) for v in items):
        raise TypeError(f"rockvdb.{fn}(): {name} must be {n} integers, got {value!r}")
    return [int(v) for v in items]


def _opt(value, check, *args):
    return None if value is None else check(value, *args)


# ---------------------------------------------------------------------------------------------
# Stage parameters: every stage's keywords, defaults, units, ranges and help come from its C++
# table (the one vdb_* --help and --params read), so Python cannot drift from the CLI. Python
# checks types here (TypeError naming the keyword); values, ranges and defaults are checked
# once, in C++ (ValueError).

def _table(stage):
    return _json.loads(_rockvdb.schema(stage))


_CHECKS = {"int": _int, "float": _float, "bool": _bool}


def _stage_params(table, fn, params):
    """Keyword arguments as the JSON text of the stage's parameters (CLI spelling)."""
    rows = {r["python"]: r for r in table["params"]}
    out = {}
    for key, value in params.items():
        row = rows.get(key)
        if row is None:
            import difflib
            close = difflib.get_close_matches(key, list(rows), 1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise TypeError(f"rockvdb.{fn}() got an unexpected keyword argument '{key}'{hint}")
        kind = row["type"]
        if kind in _CHECKS:
            value = _CHECKS[kind](value, key, fn)
        elif kind == "str":
            value = _os.fspath(value) if isinstance(value, _os.PathLike) else _str(value, key, fn)
        elif kind == "json":
            if isinstance(value, _os.PathLike):
                value = _os.fspath(value)
            if isinstance(value, tuple):
                value = list(value)
            if not isinstance(value, (str, dict, list)):
                raise _type_error(fn, key, "a dict, a list or a JSON file path", value)
        elif kind == "ints":
            value = _ints(value, row["count"], key, fn)
        else:
            value = _floats(value, row["count"], key, fn)
        bad = _non_finite(value)
        if bad is not None:
            # (JSON has no NaN: the C++ side would only see a parse error)
            raise ValueError(f"{fn}: {key} must be finite (got {bad})")
        out[row["name"]] = value
    return _json.dumps(out, allow_nan=False)


def _non_finite(value):
    """The first NaN or infinity in a number, list or dict (None when there is none)."""
    import math
    if isinstance(value, float) and not math.isfinite(value):
        return value
    items = value.values() if isinstance(value, dict) else value if isinstance(value, (list, tuple)) else ()
    for v in items:
        bad = _non_finite(v)
        if bad is not None:
            return bad
    return None


def _shown(value):
    if isinstance(value, list):
        return "(" + ", ".join(_shown(v) for v in value) + ")"
    return repr(value)


def _python_spelling(message, table):
    """@a message with each of the table's CLI names (--tile-size, tile-size) in the Python
    spelling (tile_size)."""
    import re
    for r in sorted(table["params"], key=lambda r: -len(r["name"])):
        if "-" in r["name"]:
            message = re.sub(r"(?<![\w-])(--)?" + re.escape(r["name"]) + r"(?![\w-])",
                             r["python"], message)
    return message


class _spelt:
    """A block whose ValueError speaks the Python spelling of @a table's rows."""

    def __init__(self, table):
        self.table = table

    def __enter__(self):
        return self

    def __exit__(self, kind, error, trace):
        if kind is ValueError:
            raise ValueError(_python_spelling(str(error), self.table)) from None
        return False


def _stage_function(table, impl, name, head, tail, before=(), after=(), exclude=()):
    """A public function over impl with the table's keywords in its signature (defaults as the
    table gives them) and a docstring listing each with its unit, default, range and help."""
    import inspect
    P = inspect.Parameter
    params = [P(b[0], P.POSITIONAL_OR_KEYWORD, default=b[1]) if isinstance(b, tuple)
              else P(b, P.POSITIONAL_OR_KEYWORD) for b in before]
    lines = [head, "", "Parameters (the same as the CLI's options, '-' spelt '_'):"]
    for r in table["params"]:
        if r["name"] in exclude:
            continue
        default = tuple(r["default"]) if isinstance(r["default"], list) else r["default"]
        params.append(P(r["python"], P.KEYWORD_ONLY, default=default))
        unit = f" {r['unit']}" if r["unit"] else ""
        rule = ""
        if r["choices"]:
            rule = "; one of " + ", ".join(r["choices"])
        elif r["range"] and r["type"] not in ("str", "bool"):
            rule = f"; {r['range']}"
        lines.append(f"  {r['python']} ({r['type']}{unit}; default {_shown(r['default'])}{rule}): "
                     f"{r['help']}.")
    for a, d in after:
        params.append(P(a, P.KEYWORD_ONLY, default=d))
    lines += ["", tail]

    def call(*args, **kwargs):
        # Only what the caller gave goes on (left out, a row takes its table default in C++);
        # unknown keywords reach _stage_params, which names the closest one.
        try:
            bound = sig.bind(*args, **{k: v for k, v in kwargs.items() if k in sig.parameters})
        except TypeError as e:  # "too many positional arguments": say whose
            raise TypeError(f"rockvdb.{name}(): {e}") from None
        unknown = {k: v for k, v in kwargs.items() if k not in sig.parameters}
        try:
            return impl(**bound.arguments, **unknown)
        except ValueError as e:
            # The table's checks speak the CLI's spelling (tile-size); a Python caller wrote
            # tile_size.
            raise ValueError(_python_spelling(str(e), table)) from None

    sig = inspect.Signature(params)
    call.__signature__ = sig
    call.__doc__ = "\n".join(lines)
    call.__name__ = call.__qualname__ = name
    call.__module__ = __name__
    return call


_ROCK_TILES = _table("rock_tiles")
_ROCK_PILE = _table("rock_pile")
_DETAIL = _table("detail")
_BLOCK_TILE = _table("block_tile")
_AMPLIFY = _table("amplify")
_FRACTAL_ROCK = _table("fractal_rock")
_FRACTAL_ROWS = _rockvdb.fractal_rows()  # which rows each mode reads, from the C++ stage
_SCATTER_ROWS = list(_FRACTAL_ROWS["scatter"])
_SINGLE_ROCK_ROWS = list(_FRACTAL_ROWS["single"])
_CARVE_ROWS = list(_FRACTAL_ROWS["carve"])


# ---------------------------------------------------------------------------------------------
# Fields

class Field:
    """A signed-distance field (metres, negative inside) that composes before baking.

    Operators: ``a | b`` union, ``a & b`` intersection, ``a - b`` difference; ``union``,
    ``intersection`` and ``difference`` take a smooth blend radius. ``bake`` turns it into a
    narrow-band level set. Made by sphere, box, capsule, plane, polytope, expression and
    BlockTile.field."""

    __slots__ = ("_f",)

    def __init__(self, native):
        self._f = native

    def eval(self, p):
        """Signed distance (m) at world point p = (x, y, z) in metres."""
        return self._f.eval(_floats(p, 3, "p", "Field.eval"))

    def bounds(self):
        """((xmin, ymin, zmin), (xmax, ymax, zmax)) in metres (infinite for unbounded fields)."""
        return self._f.bounds()

    @property
    def lipschitz(self):
        """Bound on |grad f| (1 for exact distances)."""
        return self._f.lipschitz

    @property
    def exact(self):
        """True when the values are exact Euclidean distances."""
        return self._f.exact

    @property
    def expression(self):
        """The JSON expression (as vdb_primitive expr reads it) that rebuilds this field."""
        return self._f.expression

    def _other(self, other, fn):
        if not isinstance(other, Field):
            raise _type_error(fn, "other", "a rockvdb.Field", other)
        return other._f

    def union(self, other, smooth=0.0):
        """Union with other; smooth > 0 blends within that radius (m; default 0 = hard)."""
        return Field(self._f.union(self._other(other, "Field.union"),
                                   _float(smooth, "smooth", "Field.union")))

    def intersection(self, other, smooth=0.0):
        """Intersection with other; smooth: blend radius (m; default 0 = hard)."""
        return Field(self._f.intersection(self._other(other, "Field.intersection"),
                                          _float(smooth, "smooth", "Field.intersection")))

    def difference(self, other, smooth=0.0):
        """This minus other; smooth: blend radius (m; default 0 = hard)."""
        return Field(self._f.difference(self._other(other, "Field.difference"),
                                        _float(smooth, "smooth", "Field.difference")))

    def __or__(self, other):
        return self.union(other)

    def __and__(self, other):
        return self.intersection(other)

    def __sub__(self, other):
        return self.difference(other)

    def transform(self, translate=(0, 0, 0), rotate=(0, 0, 0), scale=1.0):
        """Scale (a number or (sx, sy, sz)), rotate (XYZ Euler angles, degrees), then
        translate (m). Defaults: no change."""
        fn = "Field.transform"
        s = (_float(scale, "scale", fn) if isinstance(scale, _numbers.Real)
             else _floats(scale, 3, "scale", fn))
        return Field(self._f.transform(_floats(translate, 3, "translate", fn),
                                       _floats(rotate, 3, "rotate", fn), s))

    def warp(self, amplitude, frequency=1.0, octaves=3, seed=0):
        """Domain warp by vector fBm noise: amplitude (m), frequency (cycles per metre,
        default 1), octaves (default 3), seed (default 0)."""
        fn = "Field.warp"
        return Field(self._f.warp(_float(amplitude, "amplitude", fn),
                                  _float(frequency, "frequency", fn),
                                  _int(octaves, "octaves", fn), _int(seed, "seed", fn)))

    def tag(self, id):
        """Tag with an integer id, baked into an attribute grid (bake(attribute=...))."""
        return Field(self._f.tag(_int(id, "id", "Field.tag")))

    def __repr__(self):
        return f"<rockvdb.Field {self._f.expression[:60]}>"


_BAKE = _table("bake")


def _field_bake(self, attribute=None, **params):
    fn = "Field.bake"
    return self._f.bake(_stage_params(_BAKE, fn, params), _opt(attribute, _str, "attribute", fn))


Field.bake = _stage_function(
    _BAKE, _field_bake, "bake",
    "Bake to a narrow-band level set named 'surface' (pyopenvdb.FloatGrid).",
    "attribute: a grid name (e.g. 'block_id') to also bake the ids set with tag(), returned "
    "as (surface, ids). Fields that are not exact distances (warps, smooth blends) are "
    "renormalised by default (renormalize 'auto').",
    before=["self"], after=[("attribute", None)])
Field.bake.__qualname__ = "Field.bake"


def sphere(radius=1.0, center=(0, 0, 0)):
    """A sphere: radius (m, default 1) at center (m, default the origin). Exact distance."""
    return Field(_rockvdb.sphere(_float(radius, "radius", "sphere"),
                                 _floats(center, 3, "center", "sphere")))


def box(size=(1, 1, 1), center=(0, 0, 0), rounding=0.0):
    """An axis-aligned box of full size (m, default 1 x 1 x 1) at center (m), edges rounded
    by rounding (m, default 0)."""
    return Field(_rockvdb.box(_floats(size, 3, "size", "box"),
                              _floats(center, 3, "center", "box"),
                              _float(rounding, "rounding", "box")))


def capsule(a, b, radius):
    """A capsule: the points within radius (m) of the segment from a to b (m)."""
    return Field(_rockvdb.capsule(_floats(a, 3, "a", "capsule"), _floats(b, 3, "b", "capsule"),
                                  _float(radius, "radius", "capsule")))


def plane(point=(0, 0, 0), normal=(0, 0, 1)):
    """The half-space below a plane through point (m) with outward normal (default +z).
    Unbounded: intersect it with a bounded field before baking."""
    return Field(_rockvdb.plane(_floats(point, 3, "point", "plane"),
                                _floats(normal, 3, "normal", "plane")))


def polytope(planes, smooth=0.0):
    """A convex polytope: the intersection of half-spaces n.p <= d, planes given as
    [(nx, ny, nz, d), ...] (d in metres); smooth: blend radius of its edges (m, default 0)."""
    try:
        rows = [_floats(p, 4, f"planes[{i}]", "polytope") for i, p in enumerate(planes)]
    except TypeError as e:
        if "planes[" in str(e):
            raise
        raise _type_error("polytope", "planes", "a list of (nx, ny, nz, d)", planes) from None
    return Field(_rockvdb.polytope(rows, _float(smooth, "smooth", "polytope")))


def expression(json):
    """A field from a JSON expression (a str, or a dict / list), the language vdb_primitive
    expr reads: sphere, box, capsule, plane, polytope, union / intersection / difference
    (smooth), transform, warp, heightfield, noise_terrain, sea_cliff; "id" tags a node."""
    if isinstance(json, (dict, list)):
        json = _json.dumps(json)
    return Field(_rockvdb.expression(_str(json, "json", "expression")))


# ---------------------------------------------------------------------------------------------
# Grids

def _heightfield(path, stats=None, **params):
    fn = "heightfield"
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    grid, info = _rockvdb.heightfield(_path(path, "path", fn), _stage_params(_HEIGHTFIELD, fn, params))
    if stats is not None:
        stats.update(info)
    return grid


_HEIGHTFIELD = _table("heightfield")
heightfield = _stage_function(
    _HEIGHTFIELD, _heightfield, "heightfield",
    "A heightfield image (float EXR, metres; or 16-bit PNG, 0..65535 -> 0..1) as the level set "
    "of the terrain solid (vdb_heightfield from Python: the same entry point, the same grid). "
    "Pixel column i, row j (row 0 = first row stored) sits at x = i * cell_size, y = j * "
    "cell_size, height = value * height_scale; the solid's floor is base_depth below the "
    "lowest sample.",
    "Returns the level set 'surface' (pyopenvdb.FloatGrid); stats (a dict) receives the "
    "samples, the bake's counts and the phases. Ctrl-C raises KeyboardInterrupt.",
    before=["path"], after=[("stats", None)])


def write_heightfield(path, array):
    """Write a 2D array (rows = y, row 0 first) as a float EXR (.exr) or a 16-bit PNG (.png,
    values in 0..1), atomically."""
    import numpy as np
    if not hasattr(array, "__array__") and not isinstance(array, (list, tuple)):
        raise _type_error("write_heightfield", "array", "a 2D numpy array", array)
    _rockvdb.write_heightfield(_path(path, "path", "write_heightfield"),
                               np.asarray(array, dtype=np.float32))


def read_image(path):
    """A float EXR or 16-bit PNG (0..1) as a 2D float32 numpy array (row 0 = first row)."""
    return _rockvdb.read_image(_path(path, "path", "read_image"), "image")


def material_colour(name):
    """A ground material's colour (linear RGB in [0, 1]) as vdb_preview --texture paints it and
    the Blender add-on's default material gives it: sand, bedrock, rocks their own, any other
    name (a weight_<name> grid of vdb_arches) one hashed from the name."""
    if not isinstance(name, str):
        raise _type_error("material_colour", "name", "a str", name)
    return _rockvdb.material_colour(name)


def read_rgb_exr(path):
    """Channels R, G, B of an EXR (a normal map of fractal_rock / vdb_fractal_rock) as an
    H x W x 3 float32 numpy array, row 0 the top row."""
    return _rockvdb.read_rgb_exr(_path(path, "path", "read_rgb_exr"))


def _csg(op, grids, ids=None, **params):
    fn = "csg"
    grids = _grids(grids, "grids", fn)
    lists = []
    if ids is not None:
        if not hasattr(ids, "__iter__"):
            raise _type_error(fn, "ids", "a list with one list of id grids per input", ids)
        lists = [_grids(v, f"ids[{i}]", fn) for i, v in enumerate(ids)]
        if len(lists) != len(grids):
            raise ValueError(f"csg: ids needs one list of id grids per input grid (got "
                             f"{len(lists)} for {len(grids)})")
    return _rockvdb.csg(_str(op, "op", fn), grids, lists, _stage_params(_CSG, fn, params))


_CSG = _table("csg")
csg = _stage_function(
    _CSG, _csg, "csg",
    "Fold 'union', 'intersection' or 'difference' (the first minus the others) over level-set "
    "grids, left to right (vdb_csg from Python: the same entry point). Grids on another voxel "
    "size are resampled onto the first. Inputs are left untouched; returns a new grid.",
    "ids: one list of id grids (block_id, rock_id, material, ...) per input (default None); "
    "then returns (surface, [id grids]) with each name carried as vdb_csg carries it: a voxel "
    "takes the id of the input whose surface the result follows there (in a difference, the "
    "first input's), -1 where that input has no such grid.",
    before=["op", "grids"], after=[("ids", None)], exclude=["ids"])


def read(path, grid=None):
    """Read a float level set from a .vdb: grid names it (default: 'surface', else the file's
    only level set)."""
    return _rockvdb.read(_path(path, "path", "read"), _opt(grid, _str, "grid", "read") or "")


def write(path, grids):
    """Write grids to a .vdb atomically (temporary file + rename, Blosc compressed); grids
    without rockvdb provenance are written stamped generator 'rockvdb.write' (the caller's
    grids are left as they are). Level sets are written last, so tools that take the last
    grid read (vdb_tool) find 'surface'."""
    _rockvdb.write(_path(path, "path", "write"), _grids(grids, "grids", "write"))


def _mesh(grid, path, ids=(), **params):
    fn = "mesh"
    if isinstance(ids, pyopenvdb.FloatGrid) or not hasattr(ids, "__iter__"):
        raise _type_error(fn, "ids", "a list of id grids (pyopenvdb.FloatGrid)", ids)
    _rockvdb.mesh(_grid(grid, "grid", fn), _path(path, "path", fn), _stage_params(_MESH, fn, params),
                  [_grid(g, "ids", fn) for g in ids])


_MESH = _table("mesh")
mesh = _stage_function(
    _MESH, _mesh, "mesh",
    "Mesh a level set (tools::volumeToMesh; vdb_mesh from Python) to an .obj or .ply file "
    "with outward faces.",
    "up 'y' writes what Blender's OBJ import expects by default (and Houdini). ids: id grids "
    "on the level set's voxels (block_id, rock_id, material) written per vertex under their "
    "names, as vdb_mesh --ids does (PLY vertex properties; OBJ faces under usemtl NAME_ID). "
    "An isovalue outside the level set's band (an empty mesh) raises ValueError.",
    before=["grid", "path"], after=[("ids", ())])


def _preview(grid, path, ids=None, palette=None, weights=None, **params):
    fn = "preview"
    if palette is not None and not isinstance(palette, dict):
        raise _type_error(fn, "palette", "a dict {id: '#rrggbb'}", palette)
    text = ",".join(f"{_int(k, 'palette key', fn)}={_str(v, 'palette colour', fn)}"
                    for k, v in (palette or {}).items())
    if weights is not None and not isinstance(weights, (list, tuple)):
        raise _type_error(fn, "weights", "a list of weight_* grids", weights)
    if weights and not params.get("texture"):
        raise ValueError("preview: weights apply to texture=True (they would be ignored)")
    weight_grids = [_grid(w, "weights", fn) for w in (weights or [])]
    return _rockvdb.preview(_grid(grid, "grid", fn), _path(path, "path", fn),
                            _stage_params(_PREVIEW, fn, params), _opt(ids, _grid, "ids", fn), text,
                            weight_grids)


_PREVIEW = _table("preview")
preview = _stage_function(
    _PREVIEW, _preview, "preview",
    "Render a shaded PNG of a level set (OpenVDB ray intersector; vdb_preview from Python), "
    "framing its active voxels.",
    "ids: an id grid (e.g. material) to tint surfaces by id, palette: {id: '#rrggbb'} colours "
    "(other ids get a colour hashed from the id; default None). Returns what the image shows: "
    "{'surface': share of pixels on the surface, 'ids': {id: share}, 'materials': {name: share of "
    "pixels where it weighs most}} (shares in [0, 1]). weights: the weight_* grids texture=True "
    "blends (e.g. those Stacks.bake returns; default None).",
    before=["grid", "path"], after=[("ids", None), ("palette", None), ("weights", None)])


def provenance(grid):
    """(version, generator, params JSON text) of a grid rockvdb wrote, or None."""
    return _rockvdb.provenance(_grid(grid, "grid", "provenance"))


# ---------------------------------------------------------------------------------------------
# Block tiles and terrain amplification (implicit-blocks-rocky-scenery §4-§5)

class BlockTile:
    """A fractured block tile (implicit-blocks §4): ``params``, ``blocks``, ``discs`` and
    ``stats`` (dicts as in the tile file), and after a bake ``surface`` / ``block_id``
    (pyopenvdb.FloatGrid)."""

    def __init__(self, tile):
        self._tile = tile
        data = _json.loads(tile.to_json())
        self.params = data["params"]
        self.blocks = data["blocks"]
        self.discs = data["discs"]
        self.stats = data.get("stats", {})
        self.surface = None
        self.block_id = None

    def bake(self, stats=None, **params):
        """Bake the tile (vdb_blocks --from-tile's bake, through the same entry point); sets
        and returns (surface, block_id). Keywords: the rows of vdb_blocks' table that bake
        (BlockTile.BAKE_ROWS: periods, voxel_size, half_width, renormalize, tracker_steps,
        region, max_memory, chunks, chunk); left out, each takes the table's default
        (vdb_blocks --help). stats (a dict) receives the bake's counts, times and phases."""
        fn = "BlockTile.bake"
        for key in params:
            if key not in BlockTile.BAKE_ROWS:
                raise TypeError(f"rockvdb.{fn}() got an unexpected keyword argument '{key}' "
                                f"(it takes {', '.join(BlockTile.BAKE_ROWS)})")
        if stats is not None and not isinstance(stats, dict):
            raise _type_error(fn, "stats", "a dict", stats)
        with _spelt(_BLOCK_TILE):
            _, self.surface, self.block_id, st = _rockvdb.run_blocks(
                _stage_params(_BLOCK_TILE, fn, params), self._tile, True)
        if stats is not None:
            stats.update(st)
        return self.surface, self.block_id

    def field(self, periods=(1, 1, 1), periodic=False):
        """The tile as a rockvdb.Field: the union of its blocks over periods (default one
        tile), or with periodic=True the infinite tiling of space."""
        fn = "BlockTile.field"
        return Field(self._tile.field(_ints(periods, 3, "periods", fn),
                                      _bool(periodic, "periodic", fn)))

    def save(self, path):
        """Write the tile file (JSON 'rockvdb-tile'), atomically."""
        self._tile.save(_path(path, "path", "BlockTile.save"))

    def __repr__(self):
        return (f"<BlockTile {self.params['type']} {self.params['tile-size']} m: "
                f"{len(self.blocks)} blocks>")


# vdb_blocks' rows that bake a tile (the others define it), from the C++ tables.
_TILE_ROWS = frozenset(r["name"] for r in _table("tile")["params"])
BlockTile.BAKE_ROWS = tuple(r["python"] for r in _BLOCK_TILE["params"]
                            if r["name"] not in _TILE_ROWS)


def _block_tile(bake=True, stats=None, **params):
    fn = "block_tile"
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    native, surface, block_id, st = _rockvdb.run_blocks(_stage_params(_BLOCK_TILE, fn, params),
                                                        None, _bool(bake, "bake", fn))
    tile = BlockTile(native)
    tile.surface, tile.block_id = surface, block_id
    if stats is not None:
        stats.update(st)
    return tile


block_tile = _stage_function(
    _BLOCK_TILE, _block_tile, "block_tile",
    "Generate a fractured block tile (vdb_blocks from Python; implicit-blocks §4).",
    "fractures and authored take a list or a JSON file path. With bake=True (default) the "
    "tile is baked as vdb_blocks bakes it (the same entry point, the same grids); bake=False "
    "only generates. Returns a BlockTile. stats (a dict) receives the tile's counts (Table 1), "
    "the bake's and the phases' times, as vdb_blocks --stats writes them. Ctrl-C raises "
    "KeyboardInterrupt.",
    after=[("bake", True), ("stats", None)])


def load_tile(path):
    """Read a tile file (.tile) or a vdb_blocks .vdb; returns an unbaked BlockTile."""
    return BlockTile(_rockvdb.load_tile(_path(path, "path", "load_tile")))


def _amplify(terrain, tiles, mask=None, stats=None, **params):
    fn = "amplify"
    if terrain is None or not isinstance(terrain, (pyopenvdb.FloatGrid, str, _os.PathLike)):
        raise _type_error(fn, "terrain", "a pyopenvdb.FloatGrid level set or a terrain path",
                          terrain)
    if not isinstance(terrain, pyopenvdb.FloatGrid):
        terrain = _os.fspath(terrain)
    if isinstance(tiles, (BlockTile, str, _os.PathLike)) or not hasattr(tiles, "__iter__"):
        raise _type_error(fn, "tiles", "a list of BlockTile objects or tile paths", tiles)
    loaded, names, sources = [], [], {"tiles": []}
    for i, t in enumerate(tiles):
        if isinstance(t, BlockTile):
            loaded.append(t._tile)
            names.append(str(i))
            sources["tiles"].append(None)
        else:
            p = _path(t, f"tiles[{i}]", fn)
            loaded.append(_rockvdb.load_tile(p))
            names.append(_os.path.splitext(_os.path.basename(p))[0])
            sources["tiles"].append(p)
    mask_array = None
    if isinstance(mask, (str, _os.PathLike)):
        sources["mask"] = _os.fspath(mask)
        mask_array = _rockvdb.read_image(_os.fspath(mask), "mask")
    elif mask is not None:
        if not hasattr(mask, "__array__"):
            raise _type_error(fn, "mask", "an image path or a 2D numpy array", mask)
        mask_array = mask
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    surface, block_id, material, st = _rockvdb.amplify(terrain, loaded, names, mask_array,
                                                       _stage_params(_AMPLIFY, fn, params),
                                                       _json.dumps(sources))
    if stats is not None:
        stats.update(st)
    return surface, block_id, material


amplify = _stage_function(
    _AMPLIFY, _amplify, "amplify",
    "Amplify a terrain with block tiles (vdb_amplify from Python; implicit-blocks §5).\n\n"
    "terrain: a pyopenvdb.FloatGrid level set, or a path (heightfield image, procedural "
    "heightfield .json, level-set .vdb). tiles: BlockTile objects or tile paths (.tile / "
    ".vdb); strata name them by file stem, or by index for BlockTile objects. mask: an image "
    "path or a 2D array over the terrain's xy (blocks only where it reads >= 0.5).",
    "Returns (surface, block_id, material); stats (a dict) receives counts and times. Ctrl-C "
    "raises KeyboardInterrupt.",
    before=["terrain", "tiles"], after=[("mask", None), ("stats", None)])


def coverage(surface, ids, max_nz=0.6, region=None):
    """How much of a surface is made of blocks (rocks): the share of its surface voxels that
    carry an id, on steep ground and on gentle ground.

    surface: a level set; ids: its block_id / rock_id grid (ids >= 0; bare terrain < 0).
    Surface voxels are the inside voxels next to an outside one; steep where the level set's
    normal has |n_z| < max_nz (default 0.6). region: (xmin, ymin, xmax, ymax) in metres, the
    part of the footprint counted (default: all; keep clear of a heightfield's side walls).
    Returns {"steep": share, "gentle": share, "steep_voxels": n, "gentle_voxels": n}."""
    import numpy as np
    fn = "coverage"
    surface = _grid(surface, "surface", fn)
    ids = _grid(ids, "ids", fn)
    max_nz = _float(max_nz, "max_nz", fn)
    region = _opt(region, _floats, 4, "region", fn)
    if region is not None and not (region[0] < region[2] and region[1] < region[3]):
        raise ValueError(f"coverage: region must be (xmin, ymin, xmax, ymax) with min < max, "
                         f"got {tuple(region)}")
    if surface.activeVoxelCount() == 0:
        return {"steep": 0.0, "gentle": 0.0, "steep_voxels": 0, "gentle_voxels": 0}
    lo, hi = surface.evalActiveVoxelBoundingBox()
    lo = tuple(int(v) - 1 for v in lo)  # one voxel of margin each side
    shape = tuple(int(h) + 2 - l for l, h in zip(lo, hi))
    phi = np.zeros(shape, np.float32)
    surface.copyToArray(phi, ijk=lo)
    tag = np.zeros(shape, np.float32)
    ids.copyToArray(tag, ijk=lo)
    inside = phi <= 0
    edge = np.zeros(shape, bool)
    for axis in range(3):
        for step in (1, -1):
            edge |= inside & ~np.roll(inside, step, axis)
    edge[[0, -1], :, :] = edge[:, [0, -1], :] = edge[:, :, [0, -1]] = False
    if region is not None:
        dx = surface.transform.voxelSize()[0]
        i = np.arange(shape[0]) + lo[0]
        j = np.arange(shape[1]) + lo[1]
        keep_x = (i * dx >= region[0]) & (i * dx <= region[2])
        keep_y = (j * dx >= region[1]) & (j * dx <= region[3])
        edge &= keep_x[:, None, None] & keep_y[None, :, None]
    g = np.gradient(phi)
    norm = np.sqrt(g[0] ** 2 + g[1] ** 2 + g[2] ** 2) + 1e-12
    steep = edge & (np.abs(g[2]) / norm < max_nz)
    gentle = edge & ~steep
    has = tag >= 0
    ns, ng = int(steep.sum()), int(gentle.sum())
    return {"steep": float((has & steep).sum()) / max(ns, 1),
            "gentle": float((has & gentle).sum()) / max(ng, 1),
            "steep_voxels": ns, "gentle_voxels": ng}


# ---------------------------------------------------------------------------------------------
# Surface detail (implicit-blocks §4.2, gabor-details-implicit-surfaces §3-§4)

def _detail(grid, blend_mask=None, ids=None, stats=None, **params):
    fn = "detail"
    _grid(grid, "grid", fn)
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    id_grids = [] if ids is None else _grids(ids, "ids", fn)
    surface, info, carried = _rockvdb.detail(grid, _stage_params(_DETAIL, fn, params),
                                             _opt(blend_mask, _grid, "blend_mask", fn), id_grids)
    if stats is not None:
        stats.update(info)
    return surface if ids is None else (surface, *carried)


detail = _stage_function(
    _DETAIL, _detail, "detail",
    "Surface detail on a level set (vdb_detail from Python; implicit-blocks §4.2, Gabor details "
    "§3-§4). Returns a new, re-baked and renormalised level set (the input is untouched), "
    "named like the input ('surface' when the input has no name).",
    "direction_skeleton and blend take a dict or a JSON file path; blend needs blend_mask (a "
    "pyopenvdb.FloatGrid of weights in [0, 1]): the parameters are interpolated (gabor §4), so "
    "blends do not blur the details. voxel_size and half_width default to the input's. stats "
    "(a dict) receives the bake's counts and the phases, as vdb_detail --stats writes them. "
    "ids (a list of id grids on the input's band: block_id, material, ...) are carried onto "
    "the result as vdb_detail carries a file's id grids; then (surface, *ids) is returned. "
    "Ctrl-C raises KeyboardInterrupt.",
    before=["grid"], after=[("blend_mask", None), ("ids", None), ("stats", None)])


# ---------------------------------------------------------------------------------------------
# Game assets (issue 37): vdb_asset from Python

def _asset(grid, path=None, ids=None, mask=None, stats=None, **params):
    fn = "asset"
    _grid(grid, "grid", fn)
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    glb, info = _rockvdb.asset(grid, _stage_params(_ASSET, fn, params),
                               _opt(ids, _grid, "ids", fn), _opt(path, _path, "path", fn),
                               _opt(mask, _grid, "mask", fn))
    if stats is not None:
        stats.update(info)
    return glb


_ASSET = _table("asset")
asset = _stage_function(
    _ASSET, _asset, "asset",
    "A level set as a game asset (vdb_asset from Python): one GLB (glTF 2.0) with levels of "
    "detail, a UV atlas, normal and occlusion maps baked from the level set, y up, metres.",
    "Returns the GLB's bytes; path (a .glb) also writes them there, atomically. ids: the id "
    "grid (block_id, rock_id) that id cuts from. mask: an id grid (material, block_id) baked "
    "into a mask texture per LOD (vdb_asset --mask-grid). stats (a dict) receives each LOD's "
    "triangles, charts and distance to the level set, as vdb_asset --stats writes them. "
    "Ctrl-C raises KeyboardInterrupt.",
    before=["grid"], after=[("path", None), ("ids", None), ("mask", None), ("stats", None)])


def asset_ids(grid, ids):
    """The ids of an id grid (block_id, rock_id) on a level set's surface, sorted: what
    asset(grid, ids=ids, id=...) can cut, and what asset_each makes."""
    fn = "asset_ids"
    return _rockvdb.asset_ids(_grid(grid, "grid", fn), _grid(ids, "ids", fn))


def _asset_each(grid, ids, mask=None, stats=None, **params):
    fn = "asset_each"
    _grid(grid, "grid", fn)
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    if "id" in params:
        raise TypeError("rockvdb.asset_each() makes every id: it takes no 'id'")
    glbs, info = _rockvdb.asset_each(grid, _stage_params(_ASSET, fn, params), _grid(ids, "ids", fn),
                                     _opt(mask, _grid, "mask", fn))
    if stats is not None:
        stats.update(info)
    return dict(glbs)


asset_each = _stage_function(
    _ASSET, _asset_each, "asset_each",
    "Every block or rock of an id grid as its own game asset (vdb_asset --each-id from "
    "Python), each named <name>_<id>.",
    "Returns {id: GLB bytes}. mask: an id grid baked into a mask texture (as asset). stats (a "
    "dict) receives each asset's statistics.",
    before=["grid", "ids"], after=[("mask", None), ("stats", None)], exclude=("id",))


def _asset_instances(points, tiles, path=None, stats=None, **params):
    fn = "asset_instances"
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    if "id" in params:
        raise TypeError("rockvdb.asset_instances() makes every unique rock: it takes no 'id'")
    glb, info = _rockvdb.asset_instances(_path(points, "points", fn), _path(tiles, "tiles", fn),
                                         _stage_params(_ASSET, fn, params),
                                         _opt(path, _path, "path", fn))
    if stats is not None:
        stats.update(info)
    return glb


asset_instances = _stage_function(
    _ASSET, _asset_instances, "asset_instances",
    "A rock pile as one GLB (vdb_asset POINTS --tiles TILES from Python): each unique rock of "
    "the tile set an asset <name>_<rock> centred on its seed, drawn at every instance of the "
    "points file (vdb_rockpile pile --points) by EXT_mesh_gpu_instancing.",
    "points and tiles are paths (pyopenvdb cannot hold points grids). Returns the GLB's bytes, "
    "the CLI's for the same paths; path (a .glb) also writes them there, atomically. stats (a "
    "dict) receives each rock's LODs and instance count. Ctrl-C raises KeyboardInterrupt.",
    before=["points", "tiles"], after=[("path", None), ("stats", None)], exclude=("id",))


# ---------------------------------------------------------------------------------------------
# Rock tiles and rock piles (aperiodic-rock-piles, arches-material-stacks §5)

def _rock_tiles(path=None, max_memory=0.0, **params):
    fn = "rock_tiles"
    target = _opt(path, _path, "path", fn)
    grid = _rockvdb.rock_tiles(_stage_params(_ROCK_TILES, fn, params),
                               _float(max_memory, "max_memory", fn))
    if target is not None:
        _rockvdb.write(target, [grid])
    return grid


rock_tiles = _stage_function(
    _ROCK_TILES, _rock_tiles, "rock_tiles",
    "A rock tile set (vdb_rockpile tiles from Python; aperiodic-rock-piles §2-§5, arches §5).",
    "Returns the tile set as a pyopenvdb.FloatGrid 'rho' (each rock's erosion state in its own "
    "slot, the description in metadata 'rockvdb:tiles'); path also writes it (atomically). "
    "max_memory (GB, 0 = 75% of RAM): a tile set estimated above it is refused before any "
    "work. Ctrl-C raises KeyboardInterrupt.",
    after=[("path", None), ("max_memory", 0.0)])


def _tile_grid(tiles, fn):
    if isinstance(tiles, (str, _os.PathLike)):
        return _os.fspath(tiles)
    if not isinstance(tiles, pyopenvdb.FloatGrid):
        raise _type_error(fn, "tiles", "a tile set grid ('rho') or a tile file path", tiles)
    return tiles


def rock_library(tiles):
    """Every rock of a tile set (a 'rho' grid or a tile file path) as a level set 'library',
    each rock in its own slot (offsets in metadata 'rockvdb:library_offsets')."""
    tiles = _tile_grid(tiles, "rock_library")
    if isinstance(tiles, str):
        tiles = pyopenvdb.read(tiles, "rho")
    return _rockvdb.rock_library(tiles)


def _rock_pile(tiles, support, stats=None, **params):
    fn = "rock_pile"
    if isinstance(support, Field):
        support = support._f
    elif isinstance(support, (str, _os.PathLike)):
        support = _os.fspath(support)
    elif not isinstance(support, pyopenvdb.FloatGrid):
        raise _type_error(fn, "support", "a pyopenvdb.FloatGrid level set, a rockvdb.Field or "
                          "a file path", support)
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    surface, rock_id, mat, info = _rockvdb.rock_pile(_tile_grid(tiles, fn), support,
                                                     _stage_params(_ROCK_PILE, fn, params))
    if stats is not None:
        stats.update(info)
    return (surface, rock_id) if mat is None else (surface, rock_id, mat)


rock_pile = _stage_function(
    _ROCK_PILE, _rock_pile, "rock_pile",
    "Fill a support with a tile set's rocks (vdb_rockpile pile from Python; rock piles §6).\n\n"
    "tiles: a 'rho' grid or a tile file path. support: a pyopenvdb.FloatGrid level set, a "
    "rockvdb.Field (e.g. rockvdb.sphere(2)), or a path (.vdb level set, .json expression, "
    "closed .obj / .stl / .ply mesh).",
    "Returns (surface, rock_id), or (surface, rock_id, material) with material >= 0; stats (a "
    "dict) receives counts, times, and each placed rock's library index (rocks), seed position "
    "(positions) and shift (shifts: voxels added to the library rock's canonical voxels). "
    "Ctrl-C raises KeyboardInterrupt.",
    before=["tiles", "support"], after=[("stats", None)])


# ---------------------------------------------------------------------------------------------
# Fractal rocks (fractal-rocks-midpoint-displacement)

# The mesh file's up axis: vdb_mesh's row (one default for every mesh written).
_MESH_UP = next(r["default"] for r in _MESH["params"] if r["name"] == "up")


def _fractal_rock(path=None, mesh_path=None, mesh_up=_MESH_UP, normal_map=False,
                  normal_map_path=None, level_set=True, **params):
    fn = "fractal_rock"
    target = _opt(path, _path, "path", fn)
    mesh_target = _opt(mesh_path, _path, "mesh_path", fn)
    map_target = _opt(normal_map_path, _path, "normal_map_path", fn)
    if mesh_up not in ("z", "y"):
        raise ValueError(f"{fn}: mesh_up must be 'z' or 'y' (got {mesh_up!r})")
    for name, flag in (("normal_map", normal_map), ("level_set", level_set)):
        if not isinstance(flag, bool):
            raise _type_error(fn, name, "a bool", flag)
    want_map = normal_map or map_target is not None
    if target is not None and not level_set:
        raise ValueError(f"{fn}: path needs level_set=True")
    grids, _, mesh = _rockvdb.run_fractal("rock", _stage_params(_FRACTAL_ROCK, fn, params), None,
                                          level_set, want_map)
    surface = grids[0] if grids else None
    if mesh_target is not None:
        _rockvdb.write_mesh(mesh["points"], mesh["triangles"], mesh["normals"], mesh.get("uvs"),
                            mesh.get("triangle_uvs"), mesh_target, mesh_up)
    if map_target is not None:
        # Turned as the mesh file is (object space), the space named in the EXR's header.
        _rockvdb.write_normal_map(map_target, mesh["normal_map"], mesh["normal_space"], mesh_up)
    if target is not None:
        _rockvdb.write(target, [surface])
    return surface, mesh


fractal_rock = _stage_function(
    _FRACTAL_ROCK, _fractal_rock, "fractal_rock",
    "One fractal rock (vdb_fractal_rock from Python; fractal-rocks-midpoint-displacement "
    "§2-§8): an icosahedron refined by deterministic midpoint displacement, rough on top and "
    "smooth below, with subdivision damping or plain midpoint displacement.",
    "Returns (surface, mesh): surface is the level set (a pyopenvdb.FloatGrid 'surface'; None "
    "with level_set=False), mesh a dict of numpy arrays: points (N x 3, m, z up), triangles "
    "(M x 3), normals (N x 3), and with normal_map=True also uvs, triangle_uvs and normal_map "
    "(H x W x 3 floats, the layout of vdb_fractal_rock --help; normal_space 'object': "
    "rockvdb's z-up frame, or 'tangent') and normal_space. path, mesh_path (.obj / .ply; "
    "mesh_up 'z' or 'y') and normal_map_path (.exr: an object-space map turned with mesh_up, "
    "as the CLI writes it) also write the files (atomically). "
    "Ctrl-C raises KeyboardInterrupt.",
    after=[("path", None), ("mesh_path", None), ("mesh_up", _MESH_UP), ("normal_map", False),
           ("normal_map_path", None), ("level_set", True)],
    exclude=_SCATTER_ROWS + _CARVE_ROWS)


def _fractal_scatter(ground=None, path=None, stats=None, mesh=False, **params):
    fn = "fractal_scatter"
    target = _opt(path, _path, "path", fn)
    if isinstance(ground, (str, _os.PathLike)):
        ground = _os.fspath(ground)
    elif ground is not None and not isinstance(ground, pyopenvdb.FloatGrid):
        raise _type_error(fn, "ground", "None (the plane z = 0), a heightfield image or .vdb "
                          "path, or a pyopenvdb.FloatGrid level set", ground)
    if stats is not None and not isinstance(stats, dict):
        raise _type_error(fn, "stats", "a dict", stats)
    if not isinstance(mesh, bool):
        raise _type_error(fn, "mesh", "a bool", mesh)
    written, info, meshes = _rockvdb.run_fractal(
        "scatter", _stage_params(_FRACTAL_ROCK, fn, params), ground, mesh=mesh)
    if stats is not None:
        stats.update(info)
    surface, rock_id = written[-1], written[0]
    grids = (surface, rock_id) if len(written) == 2 else (surface, rock_id, written[1])
    if target is not None:
        _rockvdb.write(target, written)
    return grids + (meshes,) if mesh else grids


fractal_scatter = _stage_function(
    _FRACTAL_ROCK, _fractal_scatter, "fractal_scatter",
    "Fractal rocks scattered on a ground (vdb_fractal_rock --count from Python; "
    "fractal-rocks §1: rocks distributed by another fBm), none interpenetrating, each partly "
    "sunk (embed).\n\nground: None (the plane z = 0), a heightfield image path (.exr / .png, "
    "ground_cell_size, ground_height_scale), a level set .vdb path (ground_grid) or a "
    "pyopenvdb.FloatGrid level set. count is required (>= 1).",
    "Returns (surface, rock_id), or (surface, rock_id, material) with material >= 0, and with "
    "mesh=True a last item mesh (points, triangles and rock per triangle as numpy arrays); stats (a dict) receives counts (asked, placed, "
    "rejections), times and each rock's position, orient (x, y, z, w) and extent. path also "
    "writes the grids. Ctrl-C raises KeyboardInterrupt.",
    before=[("ground", None)], after=[("path", None), ("stats", None), ("mesh", False)],
    exclude=_SINGLE_ROCK_ROWS + _CARVE_ROWS)


def _fractal_carve(solid, path=None, **params):
    fn = "fractal_carve"
    target = _opt(path, _path, "path", fn)
    if isinstance(solid, (str, _os.PathLike)):
        solid = _os.fspath(solid)
    elif not isinstance(solid, pyopenvdb.FloatGrid):
        raise _type_error(fn, "solid", "a level set .vdb path or a pyopenvdb.FloatGrid", solid)
    (surface, cave), _, _ = _rockvdb.run_fractal("carve", _stage_params(_FRACTAL_ROCK, fn, params),
                                                 solid)
    if target is not None:
        _rockvdb.write(target, [surface, cave])
    return surface, cave


fractal_carve = _stage_function(
    _FRACTAL_ROCK, _fractal_carve, "fractal_carve",
    "A cave (vdb_fractal_rock --carve from Python; fractal-rocks §9: 'subtract concatenated "
    "rocks out of a quadric volume'): a random walk of count rocks from carve_start along "
    "carve_direction, united and subtracted from the solid (a level set path or grid), on the "
    "solid's voxels.",
    "Returns (surface, cave): the carved solid (named like the input) and the chain's level set "
    "'cave'. path also writes both. Ctrl-C raises KeyboardInterrupt.",
    before=["solid"], after=[("path", None)],
    exclude=_SINGLE_ROCK_ROWS + list(_FRACTAL_ROWS["ground"]))


# ---------------------------------------------------------------------------------------------
# Material stacks (arches-material-stacks-terrain §3, §6)

_ARCHES = _table("arches")
_ARCHES_GROUND = ("sand", "bedrock", "rocks")
_IMAGE_EXTENSIONS = (".exr", ".png")


def _arches_terrain(terrain, fn):
    """The terrain row's JSON and the grid given in memory, if any."""
    if isinstance(terrain, pyopenvdb.FloatGrid):
        return {"type": "level_set", "grid": terrain.name}, terrain
    if isinstance(terrain, (str, _os.PathLike)):
        path = _os.fspath(terrain)
        ext = _os.path.splitext(path)[1].lower()
        if ext == ".vdb":
            return {"type": "level_set", "file": path}, None
        if ext in _IMAGE_EXTENSIONS:
            return {"type": "heightfield", "file": path}, None
        return path, None  # a JSON file (or JSON text) of a terrain node
    if isinstance(terrain, dict):
        return terrain, None
    raise _type_error(fn, "terrain", "a terrain node (dict), a .json / .vdb / heightfield image "
                      "path or a pyopenvdb.FloatGrid level set", terrain)


def _materials(value, fn):
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        raise _type_error(fn, "material", "a material name or a sequence of names", value)
    return list(names)


class Stacks:
    """Material stacks (vdb_arches from Python; arches §3): a 2D grid of stacks, each a list of
    (material, thickness) layers bottom up - air, water, sand, bedrock, rocks; an air layer
    between bedrock is an overhang, arch or cave. Thicknesses are whole quanta, so volumes are
    exact.

        s = rockvdb.Stacks.from_scene("samples/data/arches_strata.json")  # or Stacks(terrain, ...)
        s.sculpt([(12, 12, 20)], radius=3, mode="carve")   # edits (§4): sculpt, deposit, erode
        grids = s.bake()   # {name: grid}: vdb_arches' grids, bit for bit
        s.save("terrain.stacks"); s = rockvdb.Stacks.load("terrain.stacks")

    Stacks(terrain, ...) builds the stacks of a terrain: a terrain node (dict: strata,
    heightfield, noise_terrain, sea_cliff, level_set or any solid expression), a .json file of
    one, a heightfield image (.exr / 16-bit .png, 1 m spacing), a level set .vdb, or a
    pyopenvdb.FloatGrid level set; Stacks.from_scene(path) reads a vdb_arches scene file. With
    stabilize=True (the default) the stacks are stabilised at once, as vdb_arches does, then
    the scene's edits are applied. stabilize_stats holds that run's counts and time,
    edit_stats one entry per edit made so far."""

    __slots__ = ("_s", "stabilize_stats", "edit_stats")

    def __init__(self, terrain, **params):
        _init_stacks(self, terrain, **params)

    @classmethod
    def _wrap(cls, native, stats=None, edits=None):
        s = object.__new__(cls)
        s._s = native
        s.stabilize_stats = stats
        s.edit_stats = list(edits or [])
        return s

    @classmethod
    def from_scene(cls, path, **params):
        """The stacks of a vdb_arches scene file (keywords override its keys, as command-line
        options do); relative paths in its terrain resolve against its folder."""
        fn = "Stacks.from_scene"
        scene = _path(path, "path", fn)
        with _spelt(_ARCHES):
            native, stats, edits = _rockvdb.arches_build(_stage_params(_ARCHES, fn, params), scene, None)
        return cls._wrap(native, stats, edits)

    @classmethod
    def load(cls, path):
        """Stacks saved by save() or vdb_arches --stacks (.stacks)."""
        return cls._wrap(_rockvdb.arches_load(_path(path, "path", "Stacks.load")))

    def save(self, path):
        """Write a .stacks file with the scene parameters (atomic); vdb_arches --from-stacks
        and Stacks.load continue from it."""
        path = _path(path, "path", "Stacks.save")
        if not path.endswith(".stacks"):
            raise ValueError(f"Stacks.save: the path must end in .stacks (got '{path}')")
        self._s.save(path)

    def stabilize(self):
        """Stabilise (§3.4) at the scene's repose angles: merge and sort the granular layers
        between bedrock, then slide sand and rocks down every slope steeper than their angle.
        Bedrock never moves; every material's volume is kept exactly. Returns the run's counts
        and time (moves is 0 when the stacks were already at rest). Before any edit this sets
        the scene's stabilize; after edits it is recorded as an edit {"tool": "stabilize"}.
        Ctrl-C raises KeyboardInterrupt and leaves the stacks as they were."""
        stats = self._s.stabilize()
        self.stabilize_stats = stats
        return stats

    def edit(self, edit):
        """Apply one edit (§4), a dict {"tool": "sculpt" | "crack" | "tunnel" | "deposit" |
        "erode" | "stabilize", ...} as a scene's "edits" list holds them (the methods of those
        names make them), and stabilise what it changed. It is recorded in params["edits"], so bakes
        replay through vdb_arches. Returns what it changed (stacks, their window, the change
        of each material in quanta) and its time. A bad edit raises ValueError naming its
        index and key, and changes nothing; so does Ctrl-C (KeyboardInterrupt)."""
        if not isinstance(edit, dict):
            raise _type_error("Stacks.edit", "edit", "a dict {\"tool\": ...}", edit)
        stats = self._s.edit(_json.dumps(edit))
        self.edit_stats.append(stats)
        return stats

    # The rows a bake may change (the other rows made the stacks), from the C++ stage.
    BAKE_ROWS = tuple(r.replace("-", "_") for r in _rockvdb.arches_bake_rows())

    def bake(self, material="all", *, path=None, points_path=None, **rows):
        """Bake the ground and material surfaces (§3.3, §6; the kernel row) as narrow-band level sets.

        material: 'all' (default) -> {name: grid} of what vdb_arches writes, in its file order:
        'material' (ids), 'rock_id' (with rock_tiles), the 'weight_<material>' fog grids, one
        level set per ground material present ('sand', 'bedrock', 'rocks') and 'surface' last;
        'surface' (or 'ground') -> the ground (sand, bedrock and rocks under one
        convolution); 'sand', 'bedrock', 'rocks' or 'water' -> that material's level set (empty
        when absent); 'material' -> (surface, material ids: sand 2, bedrock 3, rocks 4 unless
        material_ids says otherwise); 'weights' -> [weight_<material>]: per band voxel, the
        share of each ground material's visible faces around it (§6, 0..1), for shaders to
        blend textures by. The same grid is the same bit for bit whichever call makes it.

        Keywords: the bake's rows of the table, Stacks.BAKE_ROWS (kernel, reach, voxel_size, half_width,
        max_memory, weights - False: 'all' without the weight grids - and material_ids), as
        vdb_arches --help gives them (left out: the stacks' scene; the other rows made the
        stacks); provenance records them, so the grids replay through vdb_arches --params.
        path also writes the grids (atomically) in vdb_arches' order: ids, weights and material
        level sets, the ground last (vdb_tool acts on the last grid). points_path (with
        rock_tiles) writes the rocks instanced in rock layers as a VDB points grid 'rocks' (P,
        orient, pscale, variant, pivot, id, rock, tile), as vdb_arches --points."""
        fn = "Stacks.bake"
        _str(material, "material", fn)
        target = _opt(path, _path, "path", fn)
        points = _opt(points_path, _path, "points_path", fn)
        overrides = _stage_params(_ARCHES, fn, {k: v for k, v in rows.items() if v is not None})
        with _spelt(_ARCHES):
            grids = self._s.bake(material, overrides, points)
        if target is not None:
            if material == "all":
                ordered = list(grids.values())
            elif material == "weights":
                ordered = list(grids)
            elif isinstance(grids, tuple):
                ordered = [grids[1], grids[0]]
            else:
                ordered = [grids]
            _rockvdb.write(target, ordered)
        return grids

    def layers(self, i, j):
        """Stack (i, j)'s layers bottom up as (material name, thickness in m); stack (i, j)
        covers x in [x0 + i·s, x0 + (i+1)·s), y likewise, and starts at z0 (origin)."""
        fn = "Stacks.layers"
        return self._s.layers(_int(i, "i", fn), _int(j, "j", fn))

    def arrays(self):
        """Every layer as numpy arrays (runs merged, stacks in order j·nx + i): offsets
        (nx·ny + 1; stack k's layers are offsets[k]:offsets[k+1]), material (ids: air 0, water
        1, sand 2, bedrock 3, rocks 4), bottom and thickness in quanta (exact integers) and
        bottom_m / thickness_m in metres."""
        d = self._s.arrays()
        q, z0 = self.quantum, self.origin[2]
        d["bottom_m"] = z0 + d["bottom"] * q
        d["thickness_m"] = d["thickness"] * q
        return d

    def top(self, material=_ARCHES_GROUND):
        """(ny, nx) heights (m) of the top of the highest layer of material (a name or names;
        default the ground: sand, bedrock, rocks); NaN where a stack has none."""
        return self._s.top(_materials(material, "Stacks.top"))

    def thickness(self, material):
        """(ny, nx) total thickness (m) of material (a name or names) in each stack."""
        return self._s.thickness(_materials(material, "Stacks.thickness"))

    def volume(self, material):
        """Total volume of material (m³), exact to the quantum: quanta · s² · q."""
        n = self._s.volume_quanta(_str(material, "material", "Stacks.volume"))
        return n * self.cell_size * self.cell_size * self.quantum

    @property
    def shape(self):
        """(ny, nx): stacks along y and x."""
        return self._s.shape

    @property
    def cell_size(self):
        """Stack size s (m)."""
        return self._s.cell_size

    @property
    def origin(self):
        """(x0, y0, z0) in metres: the corner of stack (0, 0) and the bottom of every stack."""
        return self._s.origin

    @property
    def quantum(self):
        """Thickness unit q (m)."""
        return self._s.quantum

    @property
    def bytes(self):
        """Bytes the stacks occupy (delta-coded layers, counts, block offsets)."""
        return self._s.bytes

    @property
    def layer_count(self):
        """Stored layers (codes) over all stacks."""
        return self._s.layer_count

    @property
    def params(self):
        """The scene (the table's keys) that made these stacks; 'stabilize' is True once they
        are stabilised."""
        return _json.loads(self._s.params)

    def __eq__(self, other):
        return isinstance(other, Stacks) and self._s == other._s

    __hash__ = None

    def __repr__(self):
        ny, nx = self.shape
        return (f"<rockvdb.Stacks {nx} x {ny} stacks of {self.cell_size} m, {self.layer_count} "
                f"layers, {self.bytes} bytes>")


def _build_stacks(terrain, **params):
    fn = "Stacks"
    node, grid = _arches_terrain(terrain, fn)
    params["terrain"] = node
    return _rockvdb.arches_build(_stage_params(_ARCHES, fn, params), None, grid)


_stacks_factory = _stage_function(
    _ARCHES, _build_stacks, "Stacks", Stacks.__doc__,
    "Keywords are vdb_arches' options ('-' spelt '_'). Ctrl-C raises KeyboardInterrupt.",
    before=["terrain"], exclude=["terrain"])


def _init_stacks(self, *args, **kwargs):
    self._s, self.stabilize_stats, edits = _stacks_factory(*args, **kwargs)
    self.edit_stats = list(edits)


# The edit tools' methods (Stacks.sculpt, .deposit, .erode): keywords, defaults and help from
# the C++ tool table (ops/arches/Edits.cc), the one place they are defined.
_EDIT_TOOLS = _json.loads(_rockvdb.arches_edit_tools())


def _edit_method(tool):
    import inspect
    spec = _EDIT_TOOLS[tool]
    P = inspect.Parameter
    params = [P("self", P.POSITIONAL_OR_KEYWORD)]
    lines = [spec["help"] + " (an edit; see Stacks.edit).", "", "Keys:"]
    # Positional: the keys up to the last required one, in the table's order (erode's center
    # may give way to points: it and what follows it then default to None, the table's own
    # check naming what is missing); the rest keyword-only.
    last = max((n for n, k in enumerate(spec["keys"]) if k["required"]), default=-1)
    positional, optional = spec["keys"][:last + 1], spec["keys"][last + 1:]
    defaulted = False
    for k in positional:
        defaulted = defaulted or not k["required"]
        params.append(P(k["name"], P.POSITIONAL_OR_KEYWORD, **({"default": None} if defaulted else {})))
        lines.append(f"  {k['name']} ({'required' if k['required'] else 'optional'}): {k['help']}.")
    for k in optional:
        params.append(P(k["name"], P.KEYWORD_ONLY, default=None))
        shown = "" if k["default"] is None else f"; default {k['default']!r}"
        if k["range"]:
            shown += f"; {k['range']}"
        if k["choices"]:
            shown += "; one of " + ", ".join(k["choices"])
        lines.append(f"  {k['name']} (optional{shown}): {k['help']}.")
    lines += ["", "Returns the edit's stats (Stacks.edit). Keys left out take their defaults."]
    sig = inspect.Signature(params)

    def method(*args, **kwargs):
        bound = sig.bind(*args, **kwargs)
        self = bound.arguments.pop("self")
        edit = {"tool": tool}
        for name, value in bound.arguments.items():
            if value is not None:
                edit[name] = value  # (tuples become JSON lists)
        return self.edit(edit)

    method.__signature__ = sig
    method.__doc__ = "\n".join(lines)
    method.__name__ = tool
    method.__qualname__ = "Stacks." + tool
    return method


for _tool in ("sculpt", "crack", "tunnel", "deposit", "erode"):
    setattr(Stacks, _tool, _edit_method(_tool))


Stacks.__signature__ = _stacks_factory.__signature__
Stacks.__doc__ = _stacks_factory.__doc__
__all__.append("Stacks")
