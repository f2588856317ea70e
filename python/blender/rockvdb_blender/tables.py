# SPDX-License-Identifier: Apache-2.0
"""Blender properties made from the stage tables (rockvdb's C++ tables, through
rockvdb._rockvdb.schema): each row's name, type, unit, default, range, group and help become
one operator property. Nothing here restates a default or a range: a row's default is the
property's default, its range the property's soft limits (a value typed outside them reaches
the stage, which reports it as typed), its help the tooltip.

Rows whose default stands for something else are never shown as their sentinel:
- a derived row (the table's rule fills it: "0.002 x tile-size") gets a check box
  ``auto_<name>``, on by default, beside a greyed field showing the value the rule gives
  (rockvdb._rockvdb.derive); unticked, the field is editable and passed;
- a row that is unset by default (null: a region, an optional axis) gets a check box
  ``use_<name>``; the value is passed only when the box is on, and its widget starts at a
  value in the row's range.
Vectors of three get X / Y / Z labels (a translation, a length or plain XYZ subtype), every
choice is a drop-down, rows that may name a file have a file browser."""
import json

import bpy

import rockvdb
from rockvdb import _rockvdb

# Rows the panels leave out: how a bake is split across machines (vdb_merge, Dask), which
# has no meaning for one bake inside Blender.
SKIPPED = frozenset({"chunks", "chunk"})

UNIT_TEXT = {"m": "m", "degrees": "°", "cells": "cells", "voxels": "voxels"}


def table(stage):
    """The stage's table as rockvdb describes it: {"op", "summary", "params": [rows]}."""
    return json.loads(_rockvdb.schema(stage))


def derived_values(stage, given=None):
    """What the parameters @a given (table names) stand for, every derived row filled by its
    rule; None when they are not a valid call (the stage will say why when run)."""
    try:
        return json.loads(_rockvdb.derive(stage, json.dumps(given or {})))
    except (ValueError, TypeError):
        return None


def rows_of(stage, function, prefix="", positional=()):
    """The rows of @a stage's table that @a function (a rockvdb stage function) takes as
    keywords (and the @a positional ones it takes as rows), in table order, each with "prop":
    the property's name (prefix + python name), and for a derived row "auto": its rule's
    value at the table's defaults."""
    import inspect
    taken = {p.name for p in inspect.signature(function).parameters.values()
             if p.kind == p.KEYWORD_ONLY} | set(positional)
    defaults = derived_values(stage) or {}
    out = []
    for row in table(stage)["params"]:
        if row["python"] in taken and row["name"] not in SKIPPED:
            extra = {"prop": prefix + row["python"]}
            if row["derived"]:
                extra["auto"] = defaults.get(row["name"])
            out.append(dict(row, **extra))
    return out


def _tooltip(row):
    text = row["help"]
    if row["unit"]:
        text += f" ({UNIT_TEXT.get(row['unit'], row['unit'])})"
    if row["range"] and row["type"] not in ("str", "bool", "json"):
        text += f"; {row['range']}"
    return text


def _limits(row, integer):
    """Soft limits (what dragging and the slider reach) from the row's range: a closed end is
    itself, an open integer end the next integer, an open real end itself (Blender has no open
    bounds). The hard limits stay Blender's own, so that a value typed outside the range
    reaches the stage, whose one-line error names the value as typed."""
    kw = {}
    lo, hi = row["min"], row["max"]
    if lo is not None:
        kw["soft_min"] = int(lo) + 1 if integer and row["min_open"] else (int(lo) if integer else float(lo))
    if hi is not None:
        kw["soft_max"] = int(hi) - 1 if integer and row["max_open"] else (int(hi) if integer else float(hi))
    return kw


def _in_range(row, integer, value=None):
    """@a value when the row's range holds it; else (and without one: a row with no default) a
    widget's start inside the range: 0 or 1 when it holds them, else next to its floor."""
    if value is None or not _inside(row, value):
        value = next((v for v in (0, 1) if _inside(row, v)), None)
        lo, hi = row["min"], row["max"]
        if value is None and lo is None:  # (a range with a ceiling only)
            value = hi - 1 if row["max_open"] else hi
        elif value is None:
            if not row["min_open"]:
                value = lo
            elif integer:
                value = lo + 1
            else:
                value = (lo + hi) / 2 if hi is not None else lo + 1
    return int(value) if integer else float(value)


def _inside(row, v):
    lo, hi = row["min"], row["max"]
    return ((lo is None or v > lo or (v == lo and not row["min_open"])) and
            (hi is None or v < hi or (v == hi and not row["max_open"])))


def _subtype(row):
    """X / Y / Z labels for a vector of three: a translation (a point, m), a length (sizes, m)
    or plain XYZ (a direction, periods, factors)."""
    if row["count"] != 3:
        return "NONE"
    if row["unit"] == "m":
        return "XYZ_LENGTH" if row["python"] in ("size",) else "TRANSLATION"
    return "XYZ"


def make_property(row):
    """The bpy property for one row (a bpy.props deferred property)."""
    name = row["python"].replace("_", " ").capitalize()
    desc = _tooltip(row)
    kind = row["type"]
    default = row["auto"] if row.get("derived") else row["default"]
    unset = default is None
    if kind == "bool":
        return bpy.props.BoolProperty(name=name, description=desc,
                                      default=bool(default) if not unset else False)
    if kind in ("int", "ints", "float", "floats"):
        integer = kind in ("int", "ints")
        kw = _limits(row, integer)
        if unset:
            d = _in_range(row, integer)
            d = tuple([d] * row["count"]) if row["count"] > 1 else d
        elif row["count"] > 1:
            d = tuple(_in_range(row, integer, v) for v in default)
        else:
            d = _in_range(row, integer, default)
        if integer:
            if kind == "ints":
                return bpy.props.IntVectorProperty(name=name, description=desc, size=row["count"],
                                                   default=d, subtype=_subtype(row), **kw)
            return bpy.props.IntProperty(name=name, description=desc, default=d, **kw)
        unit = {"unit": "LENGTH"} if row["unit"] == "m" else {}
        if row["unit"] == "degrees":
            unit = {}  # degrees as the table gives them (Blender's ROTATION unit is radians)
        if kind == "floats":
            return bpy.props.FloatVectorProperty(name=name, description=desc, size=row["count"],
                                                 default=tuple(float(v) for v in d), precision=3,
                                                 subtype=_subtype(row), **unit, **kw)
        return bpy.props.FloatProperty(name=name, description=desc, default=float(d),
                                       precision=3, **unit, **kw)
    if kind == "str" and row["choices"]:
        items = [(c, c.replace("_", " ").capitalize(), "") for c in row["choices"]]
        return bpy.props.EnumProperty(name=name, description=desc, items=items,
                                      default=default if not unset else row["choices"][0])
    # str without choices, json (text, or a file path): text, with a file browser where the
    # row may name a file.
    if kind == "json":
        desc += " (JSON text, or a .json file)"
        d = "" if unset else json.dumps(default)
    else:
        d = "" if unset else str(default)
    sub = {"subtype": "FILE_PATH"} if row.get("file") else {}
    return bpy.props.StringProperty(name=name, description=desc, default=d, **sub)


def annotations(rows):
    """Operator annotations for @a rows: the value property, auto_<prop> for derived rows,
    use_<prop> for unset rows."""
    ann = {}
    for row in rows:
        ann[row["prop"]] = make_property(row)
        if row["derived"]:
            ann["auto_" + row["prop"]] = bpy.props.BoolProperty(
                name="Auto", default=True,
                description=f"On: {row['derived']} (the field shows the value); off: the value "
                            "typed in the field")
        elif row["default"] is None:
            ann["use_" + row["prop"]] = bpy.props.BoolProperty(
                name="Set " + row["python"].replace("_", " "),
                description="Off: " + row["help"] + " stays unset (the stage's own choice)")
    return ann


def decimal(value):
    """A Blender float property's value as the number it shows: Blender keeps 32-bit floats
    (0.3 is 0.30000001192...), the stages take doubles, and the CLI's 0.3 is the double 0.3.
    The shortest decimal that reads back as the same 32-bit float is what was typed (or the
    table's default), so the add-on and the CLI bake the same grids for the same numbers."""
    import numpy as np
    return float(repr(np.float32(value)))


def is_length(row):
    return row["unit"] == "m" and row["type"] in ("float", "floats")


def keywords(op, rows, scale=1.0):
    """The stage keywords an operator's properties give (rows in their Python spelling):
    derived rows only when their Auto box is off, unset rows only when their use_ box is on,
    JSON text parsed. Lengths are scene lengths times @a scale (Blender's Unit Scale: metres
    per scene unit)."""
    kw = {}
    for row in rows:
        if row["derived"] and getattr(op, "auto_" + row["prop"]):
            continue
        if not row["derived"] and row["default"] is None and not getattr(op, "use_" + row["prop"]):
            continue
        value = getattr(op, row["prop"])
        s = scale if is_length(row) else 1.0
        if row["type"] == "float":
            value = decimal(value * s)
        elif row["type"] == "floats":
            value = [decimal(v * s) for v in value]
        elif row["type"] == "ints":
            value = list(value)
        elif row["type"] == "json":
            text = value.strip()
            if not text:
                continue
            if text[:1] in "[{":
                try:
                    value = json.loads(text)
                except json.JSONDecodeError as e:
                    raise ValueError(f"{row['python']}: not valid JSON ({e.msg})") from None
            else:
                value = bpy.path.abspath(text)
        elif row.get("file") and value and value != row["default"]:
            value = bpy.path.abspath(value)
        kw[row["python"]] = value
    return kw


def show_derived(op, rows, values, scale=1.0):
    """Put each derived row's value (from @a values: the call's derived_values, table names)
    into its greyed field while its Auto box is on, so that the panel shows what the stage
    used."""
    if not values:
        return
    for row in rows:
        if not row["derived"] or not getattr(op, "auto_" + row["prop"]):
            continue
        v = values.get(row["name"])
        if v is None:
            continue
        s = scale if is_length(row) else 1.0
        try:
            setattr(op, row["prop"], [x / s for x in v] if isinstance(v, list) else
                    (v / s if isinstance(v, float) else v))
        except (TypeError, ValueError, OverflowError):
            pass


def draw_row(layout, op, row):
    """One row: a derived row's field (greyed while its rule holds) with its Auto box on the
    right; an unset row's Set box before its field; any other row its field."""
    if row["derived"]:
        split = layout.split(factor=0.78, align=True)
        field = split.row(align=True)
        field.enabled = not getattr(op, "auto_" + row["prop"])
        field.prop(op, row["prop"])
        split.prop(op, "auto_" + row["prop"], text="Auto")
    elif row["default"] is None:
        line = layout.row(align=True)
        line.prop(op, "use_" + row["prop"], text="")
        sub = line.row(align=True)
        sub.enabled = getattr(op, "use_" + row["prop"])
        sub.prop(op, row["prop"])
    else:
        layout.prop(op, row["prop"])


def groups(rows):
    """@a rows by their table group, groups in the order they first appear and Resolution
    last: [(group, rows)]."""
    out = {}
    for row in rows:
        out.setdefault(row["group"], []).append(row)
    order = sorted(out, key=lambda g: (g == "Resolution", list(out).index(g)))
    return [(g, out[g]) for g in order]


def version():
    return rockvdb.__version__
