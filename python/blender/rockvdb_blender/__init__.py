# SPDX-License-Identifier: Apache-2.0
"""rockvdb for Blender: the rockvdb stages as operators (Add > rockvdb, and the N-panel's
rockvdb tab), their properties made from the stage tables, results as meshed level sets with
their ids.

Each operator rockvdb.<stage> runs the stage off the UI thread when invoked from the UI
(progress in the status bar, Esc cancels within a second, nothing half-made is left), and in
the foreground from scripts and the redo panel (F9). Results keep their parameters:
Regenerate re-runs them, Export .vdb writes the grids with the provenance the CLI writes."""

bl_info = {
    "name": "rockvdb",
    "author": "rockvdb",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Add > rockvdb, and View3D > Sidebar > rockvdb",
    "description": "Procedural rocks and rocky terrain as OpenVDB level sets: fractal rocks, "
                   "block tiles, rock piles, amplified terrain, material stacks, surface detail",
    "category": "Add Mesh",
}

import json
import os
import sys
import threading
import time

import bpy


def _find_rockvdb():
    """rockvdb's Python package: importable already (the default install prefix puts it on
    Blender's path), else where `cmake --install` put it beside this add-on (_paths.py)."""
    try:
        import rockvdb  # noqa: F401
        return
    except ImportError:
        pass
    try:
        from . import _paths
        for p in _paths.PYTHON_PATHS:
            if os.path.isdir(p) and p not in sys.path:
                sys.path.append(p)
    except ImportError:
        pass


_find_rockvdb()

import rockvdb  # noqa: E402

from . import results, stages, tables  # noqa: E402


def _one_line(e):
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__


class Run:
    """One stage call on a worker thread, watched through a rockvdb.Job."""

    def __init__(self, stage, kw, inputs):
        self.stage, self.kw, self.inputs = stage, kw, inputs
        self.job = rockvdb.Job()
        self.grids = self.error = None
        self.cancelled = self.interrupted = False
        self.thread = threading.Thread(target=self._work, daemon=True, name=f"rockvdb {stage.name}")

    def _work(self):
        try:
            with self.job:
                grids = self.stage.run_fn(self.kw, self.inputs)
                extra = {}
                if isinstance(grids, tuple):  # (grids, what else the stage made)
                    grids, extra = grids
                # The cache file and the id points, here too: the UI thread only makes objects.
                self.grids = results.prepare(grids, self.inputs["cache"])
                self.grids.update(extra)
        except KeyboardInterrupt:  # the stage saw the cancel and stopped
            self.cancelled = self.interrupted = True
        except Exception as e:  # every failure becomes the operator's one-line report
            self.error = _one_line(e)

    def start(self):
        self.thread.start()
        return self

    def done(self):
        return not self.thread.is_alive()

    def cancel(self, timeout=5.0):
        self.job.cancel()
        self.thread.join(timeout)
        if self.grids is not None:  # it had finished: its cache file is nobody's
            try:
                os.remove(self.grids["path"])
            except OSError:
                pass
            self.grids = None
        self.cancelled = True


def _operator_props(op):
    """The properties the call set (by the caller, the panel or the redo panel), as JSON-able
    values, stored on the result for Regenerate: the others take their defaults again, and a
    scene file's keys hold where the call did not override them."""
    out = {}
    for key in op.__annotations__:
        if key in ("target",) or not op.properties.is_property_set(key):
            continue
        v = getattr(op, key)
        out[key] = list(v) if hasattr(v, "__len__") and not isinstance(v, str) else v
    return out


class _StageOperator:
    """The operator body every stage shares; the subclasses (made in _make_operator) add the
    stage and its properties."""
    stage = None
    _run = None

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def draw(self, context):
        layout = self.layout
        for name in self.stage.extra:
            layout.prop(self, name)
        for (table, rows, prefix), summary in zip(self.stage.groups, self.stage.summaries):
            box = layout.box()
            box.label(text=summary.split(":")[0])
            tables.draw_rows(box, self, rows, resolution=False)
            if any(r["resolution"] for r in rows):
                box.label(text="Resolution (not the look):")
                tables.draw_rows(box, self, rows, resolution=True)

    def _inputs(self, context):
        return self.stage.gather_fn(self, context)

    def _finish(self, context, run):
        if run.error:
            self.report({"ERROR"}, f"rockvdb.{self.stage.name}: {run.error}")
            return {"CANCELLED"}
        if run.cancelled:
            self.report({"WARNING"}, f"rockvdb.{self.stage.name}: cancelled")
            return {"CANCELLED"}
        target = bpy.data.objects.get(self.target) if self.target else None
        props = _operator_props(self)
        # Regenerate reads the same input object, whatever is active then.
        props["source"] = run.inputs.get("source", "")
        obj = results.build(context, self.stage.name, self.stage.label, run.grids, props, target)
        if run.inputs.get("source"):
            obj["rockvdb_source"] = run.inputs["source"]
        if run.inputs.get("tile"):
            obj["rockvdb_tile"] = run.inputs["tile"]
        return {"FINISHED"}

    def _prepare(self, context):
        try:
            inputs = self._inputs(context)
            inputs["cache"] = results.cache_path(self.stage.label)
            return Run(self.stage, self.stage.keywords(self), inputs)
        except Exception as e:
            self.report({"ERROR"}, f"rockvdb.{self.stage.name}: {_one_line(e)}")
            return None

    def execute(self, context):
        run = self._prepare(context)
        if run is None:
            return {"CANCELLED"}
        run._work()  # in the foreground: scripts, the redo panel
        return self._finish(context, run)

    def invoke(self, context, event):
        run = self._prepare(context)
        if run is None:
            return {"CANCELLED"}
        self._run = run.start()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _end(self, context):
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace:
            context.workspace.status_text_set(None)

    def modal(self, context, event):
        run = self._run
        if event.type == "ESC":
            run.cancel()
            self._end(context)
            self.report({"WARNING"}, f"rockvdb.{self.stage.name}: cancelled")
            return {"CANCELLED"}
        if event.type == "TIMER":
            if run.done():
                self._end(context)
                return self._finish(context, run)
            pct = int(100 * run.job.progress)
            context.window_manager.progress_update(pct)
            if context.workspace:
                context.workspace.status_text_set(
                    f"rockvdb {self.stage.label}: {run.job.phase or 'starting'} {pct}%  (Esc cancels)")
        return {"PASS_THROUGH"}


def _make_operator(stage):
    ann = dict(stage.extra)
    for _, rows, _ in stage.groups:
        ann.update(tables.annotations(rows))
    ann["target"] = bpy.props.StringProperty(options={"HIDDEN", "SKIP_SAVE"},
                                             description="Result object to regenerate in place")
    ann["source"] = bpy.props.StringProperty(options={"HIDDEN"},
                                             description="Input object (default: the active one)")
    return type(f"ROCKVDB_OT_{stage.name}", (_StageOperator, bpy.types.Operator), {
        "bl_idname": f"rockvdb.{stage.name}",
        "bl_label": stage.label,
        "bl_description": stage.summary,
        "bl_options": {"REGISTER", "UNDO"},
        "__annotations__": ann,
        "stage": stage,
    })


class ROCKVDB_OT_regenerate(bpy.types.Operator):
    """Re-run the active rockvdb result's stage with its stored parameters, in place"""
    bl_idname = "rockvdb.regenerate"
    bl_label = "Regenerate"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and bool(obj.get("rockvdb_stage"))

    def execute(self, context):
        obj = context.active_object
        props = json.loads(obj["rockvdb_operator"])
        op = getattr(bpy.ops.rockvdb, obj["rockvdb_stage"])
        return op("EXEC_DEFAULT", target=obj.name, **props)

    def invoke(self, context, event):
        obj = context.active_object
        props = json.loads(obj["rockvdb_operator"])
        op = getattr(bpy.ops.rockvdb, obj["rockvdb_stage"])
        return op("INVOKE_DEFAULT", target=obj.name, **props)


class ROCKVDB_OT_export_vdb(bpy.types.Operator):
    """Write the active rockvdb result's grids to a .vdb, with the provenance the CLI writes"""
    bl_idname = "rockvdb.export_vdb"
    bl_label = "Export .vdb"
    filepath: bpy.props.StringProperty(subtype="FILE_PATH")
    filter_glob: bpy.props.StringProperty(default="*.vdb", options={"HIDDEN"})

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and bool(obj.get("rockvdb_stage"))

    def execute(self, context):
        try:
            path = bpy.path.abspath(self.filepath)
            if not path.endswith(".vdb"):
                path += ".vdb"
            rockvdb.write(path, results.grids_of(context.active_object))
        except Exception as e:
            self.report({"ERROR"}, f"rockvdb.export_vdb: {_one_line(e)}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"wrote {path}")
        return {"FINISHED"}

    def invoke(self, context, event):
        self.filepath = context.active_object.name + ".vdb"
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


class VIEW3D_MT_rockvdb_add(bpy.types.Menu):
    bl_idname = "VIEW3D_MT_rockvdb_add"
    bl_label = "rockvdb"

    def draw(self, context):
        self.layout.operator_context = "INVOKE_DEFAULT"
        for s in stages.STAGES:
            self.layout.operator(f"rockvdb.{s.name}", text=s.label, icon=s.icon)


class VIEW3D_PT_rockvdb(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "rockvdb"
    bl_label = "rockvdb"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.operator_context = "INVOKE_DEFAULT"
        for s in stages.STAGES:
            col.operator(f"rockvdb.{s.name}", text=s.label, icon=s.icon)
        obj = context.active_object
        if obj is not None and obj.get("rockvdb_stage"):
            box = layout.box()
            box.label(text=f"{obj.name}: {obj['rockvdb_stage']} (rockvdb {obj['rockvdb_version']})")
            row = box.row(align=True)
            row.operator("rockvdb.regenerate", icon="FILE_REFRESH")
            row.operator("rockvdb.export_vdb", icon="EXPORT")


def _menu(self, context):
    self.layout.menu(VIEW3D_MT_rockvdb_add.bl_idname, icon="MESH_ICOSPHERE")


_classes = []


def register():
    _classes[:] = [_make_operator(s) for s in stages.STAGES] + [
        ROCKVDB_OT_regenerate, ROCKVDB_OT_export_vdb, VIEW3D_MT_rockvdb_add, VIEW3D_PT_rockvdb]
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.types.VIEW3D_MT_add.append(_menu)


def unregister():
    bpy.types.VIEW3D_MT_add.remove(_menu)
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    _classes.clear()
