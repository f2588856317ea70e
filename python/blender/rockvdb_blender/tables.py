# SPDX-License-Identifier: Apache-2.0
"""Blender properties made from the stage tables (rockvdb's C++ tables, through
rockvdb._rockvdb.schema): each row's name, type, unit, default, range and help become one
operator property. Nothing here restates a default or a range: a row's default is the
property's default, its closed or open range the property's min and max, its help the tooltip.

A row whose default is "unset" (null: a region, an optional axis) gets a check box
``use_<name>`` beside its value; the value is passed only when the box is on, and the
value's own widget starts at the row's range floor (a widget needs some number; it is never
passed unless the box is on)."""
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


def rows_of(stage, function, prefix="", positional=()):
    """The rows of @a stage's table that @a function (a rockvdb stage function) takes as
    keywords (and the @a positional ones it takes as rows), in table order, each with "prop":
    the property's name (prefix + python name)."""
    import inspect
    taken = {p.name for p in inspect.signature(function).parameters.values()
             if p.kind == p.KEYWORD_ONLY} | set(positional)
    out = []
    for row in table(stage)["params"]:
        if row["python"] in taken and row["name"] not in SKIPPED:
            out.append(dict(row, prop=prefix + row["python"]))
    return out


def _tooltip(row):
    text = row["help"]
    if row["unit"]:
        text += f" ({UNIT_TEXT.get(row['unit'], row['unit'])})"
    if row["derived"]:
        text += f". Default: {row['derived']}"
    if row["range"] and row["type"] not in ("str", "bool", "json"):
        text += f"; {row['range']}"
    return text


def _bounds(row, integer):
    """Property limits from the row's range: a closed end is itself, an open integer end the
    next integer; an open real end is left to the stage's own check (Blender has no open
    bounds), which reports the value out of range in one line."""
    kw = {}
    lo, hi = row["min"], row["max"]
    if lo is not None:
        kw["min"] = int(lo) + 1 if integer and row["min_open"] else (int(lo) if integer else lo)
    if hi is not None:
        kw["max"] = int(hi) - 1 if integer and row["max_open"] else (int(hi) if integer else hi)
    if not integer:
        # Blender clamps float limits to about +-3.4e38; the tables' limits are far inside.
        for k in ("min", "max"):
            if k in kw:
                kw[k] = float(kw[k])
    return kw


def _placeholder(row, integer):
    """A value widget's start for a row with no default: its range floor, else 0."""
    lo = row["min"]
    base = (int(lo) if integer else float(lo)) if lo is not None else (0 if integer else 0.0)
    if row["min_open"] and lo is not None:
        base = base + 1 if integer else base
    if row["count"] > 1:
        return tuple([base] * row["count"])
    return base


def make_property(row):
    """The bpy property for one row (a bpy.props deferred property)."""
    name = row["python"].replace("_", " ").capitalize()
    desc = _tooltip(row)
    kind, default = row["type"], row["default"]
    unset = default is None
    if kind == "bool":
        return bpy.props.BoolProperty(name=name, description=desc,
                                      default=bool(default) if not unset else False)
    if kind in ("int", "ints"):
        kw = _bounds(row, True)
        d = _placeholder(row, True) if unset else (tuple(default) if kind == "ints" else default)
        if kind == "ints":
            return bpy.props.IntVectorProperty(name=name, description=desc, size=row["count"],
                                               default=d, **kw)
        return bpy.props.IntProperty(name=name, description=desc, default=d, **kw)
    if kind in ("float", "floats"):
        kw = _bounds(row, False)
        unit = {"unit": "LENGTH"} if row["unit"] == "m" else {}
        d = _placeholder(row, False) if unset else (tuple(float(v) for v in default)
                                                    if kind == "floats" else float(default))
        if kind == "floats":
            return bpy.props.FloatVectorProperty(name=name, description=desc, size=row["count"],
                                                 default=d, precision=3, **unit, **kw)
        return bpy.props.FloatProperty(name=name, description=desc, default=d, precision=3,
                                       **unit, **kw)
    if kind == "str" and row["choices"]:
        items = [(c, c.replace("_", " ").capitalize(), "") for c in row["choices"]]
        return bpy.props.EnumProperty(name=name, description=desc, items=items,
                                      default=default if not unset else row["choices"][0])
    # str without choices, json (text, or a file path): text.
    if kind == "json":
        desc += " (JSON text, or a .json file path)"
        d = "" if unset else json.dumps(default)
    else:
        d = "" if unset else str(default)
    return bpy.props.StringProperty(name=name, description=desc, default=d)


def annotations(rows):
    """Operator annotations for @a rows: the value property, and use_<prop> for unset rows."""
    ann = {}
    for row in rows:
        ann[row["prop"]] = make_property(row)
        if row["default"] is None:
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


def keywords(op, rows):
    """The stage keywords an operator's properties give (rows in their Python spelling):
    unset rows only when their use_ box is on, JSON text parsed."""
    kw = {}
    for row in rows:
        if row["default"] is None and not getattr(op, "use_" + row["prop"]):
            continue
        value = getattr(op, row["prop"])
        if row["type"] == "float":
            value = decimal(value)
        elif row["type"] == "floats":
            value = [decimal(v) for v in value]
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
        kw[row["python"]] = value
    return kw


def draw_rows(layout, op, rows, resolution):
    """The rows that change the look (resolution=False) or only how finely it is sampled."""
    for row in rows:
        if bool(row["resolution"]) != resolution:
            continue
        if row["default"] is None:
            line = layout.row(align=True)
            line.prop(op, "use_" + row["prop"], text="")
            sub = line.row(align=True)
            sub.active = getattr(op, "use_" + row["prop"])
            sub.prop(op, row["prop"])
        else:
            layout.prop(op, row["prop"])


def version():
    return rockvdb.__version__
