# SPDX-License-Identifier: Apache-2.0
"""rockvdb for Blender: the rockvdb stages as operators (Add > rockvdb, and the N-panel's
rockvdb tab), their properties made from the stage tables, results as meshed level sets with
their ids.

Each operator rockvdb.<stage> runs the stage off the UI thread when invoked from the UI
(progress in the status bar, Esc cancels within a second, nothing half-made is left): the
stage and its mesh are made on a worker, and Blender only copies the finished arrays, a step
per timer tick. From scripts and the redo panel (F9) it runs in the foreground. Quality
Preview (the default) bakes the same parameters coarser (the rule beside the tables);
Final is the CLI's defaults. Results keep their parameters: Regenerate re-runs them, Export
.vdb writes the grids with the provenance the CLI writes."""

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
import shutil
import sys
import threading
import time

import bpy
from bpy.app.handlers import persistent


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
        self.key = None  # what makes its result (_call_key)
        self.thread = threading.Thread(target=self._work, daemon=True, name=f"rockvdb {stage.name}")

    def _work(self):
        try:
            with self.job:
                grids = self.stage.run_fn(self.kw, self.inputs)
                extra = {}
                if isinstance(grids, tuple):  # (grids, what else the stage made)
                    grids, extra = grids
                # The cache file and the mesh, here too: the UI thread only copies arrays.
                self.grids = results.prepare(grids, self.inputs["cache"], self.inputs["adaptivity"],
                                             self.inputs["scale"])
                self.grids.update(extra)
                self.grids["scale"] = self.inputs["scale"]
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


# Properties the panels use that are not the stage's: they never reach the stage, nor the
# stored call.
_UI_PROPS = ("target", "preview_voxel")


def _operator_props(op):
    """The properties the call set (by the caller, the panel or the redo panel), as JSON-able
    values, stored on the result for Regenerate: the others take their defaults again, and a
    scene file's keys hold where the call did not override them. A derived row's greyed value
    (its Auto box on) is shown, not set."""
    out = {}
    for key in op.__annotations__:
        if key in _UI_PROPS or key.startswith("show_") or not op.properties.is_property_set(key):
            continue
        if not key.startswith("auto_") and getattr(op, "auto_" + key, False):
            continue
        v = getattr(op, key)
        out[key] = list(v) if hasattr(v, "__len__") and not isinstance(v, str) else v
    return out


# The last finished call of each stage: (its key, what it prepared). The redo panel re-runs an
# operator on every change, also when a sub-panel opens or closes: an unchanged call reuses the
# grids and mesh instead of baking them again.
_last = {}


def _call_key(stage, kw, inputs):
    """What makes a call's result: its keywords and its inputs (meshes and heights by their
    bytes, a file named anywhere by its name, size and modification time: a scene or fracture
    file edited since counts), not the files it writes itself (in the cache folder)."""
    import hashlib
    h = hashlib.sha1(json.dumps(kw, sort_keys=True, default=str).encode())
    own = results.cache_dir()

    def stamp(v):
        if isinstance(v, str) and os.path.isfile(v):
            st = os.stat(v)
            h.update(f"{v}:{st.st_size}:{st.st_mtime_ns}".encode())
        elif isinstance(v, dict):
            for x in v.values():
                stamp(x)
        elif isinstance(v, (list, tuple)):
            for x in v:
                stamp(x)
    stamp(kw)
    for k in sorted(inputs):
        v = inputs[k]
        if isinstance(v, str) and v.startswith(own):
            continue
        h.update(k.encode())
        stamp(v)
        for a in (v if isinstance(v, tuple) else (v,)):
            h.update(a.tobytes() if hasattr(a, "tobytes") else repr(a).encode())
    return stage.name + ":" + h.hexdigest()


def _reuse(run, last):
    """The last call's result for @a run, the same call: its grids and mesh, its files copied to
    this call's own paths (each result owns its files: Regenerate removes a result's old ones)."""
    key, prepared, inputs = last
    if key != run.key or not os.path.isfile(prepared["path"]):
        return False
    shutil.copyfile(prepared["path"], run.inputs["cache"])
    if inputs.get("tile") and run.inputs.get("tile") and os.path.isfile(inputs["tile"]):
        shutil.copyfile(inputs["tile"], run.inputs["tile"])
    run.grids = dict(prepared, path=run.inputs["cache"])
    return True


class _StageOperator:
    """The operator body every stage shares; the subclasses (made in _make_operator) add the
    stage and its properties."""
    stage = None
    _run = None
    _steps = None

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def draw(self, context):
        layout = self.layout
        layout.row().prop(self, "quality", expand=True)
        for name in self.stage.extra:
            layout.prop(self, name)
        preview = self.quality == "PREVIEW"
        for group, rows in tables.groups(self.stage.rows()):
            key = "show_" + _group_key(group)
            box = layout.box()
            head = box.row()
            shown = getattr(self, key)
            head.prop(self, key, text=group, emboss=False,
                      icon="TRIA_DOWN" if shown else "TRIA_RIGHT")
            if not shown:
                continue
            for row in rows:
                if preview and row["python"] == "voxel_size" and self.preview_voxel > 0:
                    line = box.row()
                    line.enabled = False
                    line.label(text=f"Voxel size: {self.preview_voxel:.3g} m (Preview; Final: "
                                    "the field's value)")
                    continue
                tables.draw_row(box, self, row)

    def _finish_steps(self, context, run):
        """The result's objects, a step at a time (results.build_steps); yields None between
        steps, then the final status."""
        if run.error:
            self.report({"ERROR"}, f"rockvdb.{self.stage.name}: {run.error}")
            yield {"CANCELLED"}
            return
        if run.cancelled:
            self.report({"WARNING"}, f"rockvdb.{self.stage.name}: cancelled")
            yield {"CANCELLED"}
            return
        target = bpy.data.objects.get(self.target) if self.target else None
        props = _operator_props(self)
        # Regenerate reads the same input object, whatever is active then.
        props["source"] = run.inputs.get("source", "")
        obj = None
        for obj in results.build_steps(context, self.stage.name, self.stage.label, run.grids,
                                       props, target):
            if obj is None:
                yield None
        if run.inputs.get("source"):
            obj["rockvdb_source"] = run.inputs["source"]
        if run.inputs.get("tile"):
            obj["rockvdb_tile"] = results.cache_name(run.inputs["tile"])
        _last[self.stage.name] = (run.key, run.grids, dict(run.inputs))
        yield {"FINISHED"}

    def _prepare(self, context):
        try:
            scale = stages.unit_scale(context)
            if scale != 1.0:
                self._scene_lengths(scale)
            inputs = self._inputs(context)
            kw = self.stage.keywords(self, scale)
            voxel = self.stage.preview(kw, inputs) if self.quality == "PREVIEW" else None
            self.preview_voxel = voxel or 0.0
            inputs["adaptivity"] = results.mesh_adaptivity(self.quality)
            inputs["scale"] = scale
            key = _call_key(self.stage, kw, inputs)
            inputs["cache"] = results.cache_path(self.stage.label)
            self._show_derived(kw, scale)
            run = Run(self.stage, kw, inputs)
            run.key = key
            return run
        except Exception as e:
            self.report({"ERROR"}, f"rockvdb.{self.stage.name}: {_one_line(e)}")
            return None

    def _scene_lengths(self, scale):
        """Blender's Unit Scale (metres per scene unit) other than 1: length fields hold scene
        units, the tables' defaults are metres, so a length field the call did not set starts
        at its default in scene units (the panel then shows the table's metres)."""
        for p in self.properties.bl_rna.properties:
            if p.type != "FLOAT" or p.unit != "LENGTH" or self.properties.is_property_set(p.identifier):
                continue
            if p.array_length:
                setattr(self, p.identifier, [v / scale for v in p.default_array])
            else:
                setattr(self, p.identifier, p.default / scale)

    def _show_derived(self, kw, scale):
        """Each derived row's greyed field shows the value its rule gives for this call."""
        for table, rows, prefix in self.stage.groups:
            if any(r["derived"] for r in rows):
                given = {r["name"]: kw[prefix][r["python"]] for r in rows if r["python"] in kw[prefix]}
                tables.show_derived(self, rows, tables.derived_values(table, given), scale)

    def _inputs(self, context):
        return self.stage.gather_fn(self, context)

    def execute(self, context):
        run = self._prepare(context)
        if run is None:
            return {"CANCELLED"}
        last = _last.get(self.stage.name)
        if last is None or not _reuse(run, last):  # (the same call again: the redo panel)
            run._work()  # in the foreground: scripts, the redo panel
        status = None
        for status in self._finish_steps(context, run):
            pass
        return status

    def invoke(self, context, event):
        run = self._prepare(context)
        if run is None:
            return {"CANCELLED"}
        self._run = run.start()
        self._steps = None
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.05, window=context.window)
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
            if self._steps is not None:
                self._steps.close()  # a half-made mesh is removed
            run.cancel()
            self._end(context)
            self.report({"WARNING"}, f"rockvdb.{self.stage.name}: cancelled")
            return {"CANCELLED"}
        if event.type == "TIMER":
            if self._steps is not None:
                # The finished arrays into Blender, one step per tick: the UI answers between.
                status = next(self._steps)
                if status is not None:
                    self._end(context)
                    return status
                return {"RUNNING_MODAL"}
            if run.done():
                self._steps = self._finish_steps(context, run)
                return {"RUNNING_MODAL"}
            pct = int(100 * run.job.progress)
            context.window_manager.progress_update(pct)
            if context.workspace:
                context.workspace.status_text_set(
                    f"rockvdb {self.stage.label}: {run.job.phase or 'starting'} {pct}%  (Esc cancels)")
        return {"PASS_THROUGH"}


def _group_key(group):
    return "".join(c if c.isalnum() else "_" for c in group.lower())


QUALITY_ITEMS = [
    ("PREVIEW", "Preview", "The same parameters at a coarser voxel and a lighter mesh (the rule "
     "beside rockvdb's tables: PREVIEW_VOXELS_ACROSS voxels across the result, at most "
     "PREVIEW_COARSEST times the Final voxel): the same blocks and rocks in seconds"),
    ("FINAL", "Final", "The stage's own voxel size and vdb_mesh's mesh: the CLI's defaults, the "
     "papers' figures' resolution"),
]


def _make_operator(stage):
    ann = dict(stage.extra)
    for _, rows, _ in stage.groups:
        ann.update(tables.annotations(rows))
    ann["quality"] = bpy.props.EnumProperty(
        name="Quality", items=[(k, n, d.replace("PREVIEW_VOXELS_ACROSS",
                                                 f"{rockvdb._rockvdb.PREVIEW_VOXELS_ACROSS:g}")
                                .replace("PREVIEW_COARSEST", f"{rockvdb._rockvdb.PREVIEW_COARSEST:g}"))
                               for k, n, d in QUALITY_ITEMS],
        default="PREVIEW", description="Preview: seconds; Final: the CLI's resolution")
    ann["preview_voxel"] = bpy.props.FloatProperty(options={"HIDDEN", "SKIP_SAVE"}, default=0.0)
    for k, (group, _) in enumerate(tables.groups(stage.rows())):
        ann["show_" + _group_key(group)] = bpy.props.BoolProperty(
            name=group, default=k == 0, options={"SKIP_SAVE"},
            description=f"Show the {group} rows")
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
            box.label(text=obj.name, icon="MESH_DATA")
            box.label(text=f"{obj['rockvdb_stage']}, rockvdb {obj['rockvdb_version']}")
            missing = results.missing_cache(obj)
            if missing:
                alert = box.column()
                alert.alert = True
                alert.label(text="Grids' cache missing:", icon="ERROR")
                alert.label(text=os.path.basename(missing))
                alert.label(text="Regenerate makes it again (the mesh is kept)")
            col = box.column(align=True)
            col.operator("rockvdb.regenerate", icon="FILE_REFRESH")
            sub = col.row(align=True)
            sub.enabled = not missing
            sub.operator("rockvdb.export_vdb", icon="EXPORT")


def _menu(self, context):
    self.layout.menu(VIEW3D_MT_rockvdb_add.bl_idname, icon="MESH_ICOSPHERE")


_classes = []


@persistent
def _save_pre(*args):
    results.save_pre(*args)


@persistent
def _save_post(*args):
    results.save_post(*args)


@persistent
def _load_post(*args):
    results.load_post(*args)


def _handlers():
    """The caches follow the .blend on save; a missing one is named on load."""
    h = bpy.app.handlers
    return [(h.save_pre, _save_pre), (h.save_post, _save_post), (h.load_post, _load_post)]


def register():
    _classes[:] = [_make_operator(s) for s in stages.STAGES] + [
        ROCKVDB_OT_regenerate, ROCKVDB_OT_export_vdb, VIEW3D_MT_rockvdb_add, VIEW3D_PT_rockvdb]
    for c in _classes:
        bpy.utils.register_class(c)
    bpy.types.VIEW3D_MT_add.append(_menu)
    for handlers, fn in _handlers():
        if fn not in handlers:
            handlers.append(fn)


def unregister():
    for handlers, fn in _handlers():
        if fn in handlers:
            handlers.remove(fn)
    bpy.types.VIEW3D_MT_add.remove(_menu)
    for c in reversed(_classes):
        bpy.utils.unregister_class(c)
    _classes.clear()
