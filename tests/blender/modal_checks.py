# SPDX-License-Identifier: Apache-2.0
"""Run by Blender with a window (under Xvfb, --enable-event-simulate): the operators as an
artist starts them (INVOKE_DEFAULT: modal, the stage on a worker thread), Esc, and Ctrl-Z.
Steps run from a timer, so Blender's event loop runs between them; the report goes to the
last argument as JSON.
usage: xvfb-run blender --factory-startup --enable-event-simulate --python modal_checks.py -- OUT.json
(BLENDER_USER_SCRIPTS: a folder whose addons/ holds rockvdb_blender; PYTHONPATH: rockvdb)"""
import json
import sys
import threading
import time

import addon_utils
import bpy

OUT = sys.argv[-1]
addon_utils.enable("rockvdb_blender", default_set=True)
win = bpy.context.window_manager.windows[0]
area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
report, state = {"errors": []}, {"step": 0}


def names():
    return sorted(o.name for o in bpy.data.objects)


def workers():
    return [t.name for t in threading.enumerate() if t.name.startswith("rockvdb ")]


def op(name, **kw):
    with bpy.context.temp_override(window=win, area=area):
        return list(getattr(bpy.ops.rockvdb, name)("INVOKE_DEFAULT", **kw))


def tick():
    try:
        s, now = state["step"], time.time()
        state["step"] += 1
        if s == 0:
            report["start"] = names()
            # A tile at 2 cm: many seconds of work, so it is still running at the next tick.
            report["invoke"] = op("block_tile", voxel_size=0.02)
            state["t"] = now
            return 0.5
        if s == 1:  # the UI ticks while the stage works
            report["tick_after"] = now - state["t"]
            report["during"] = names()
            report["workers_during"] = workers()
            win.event_simulate(type="ESC", value="PRESS")
            state["t"] = now
            return 1.0
        if s == 2:  # Esc: the worker has stopped, nothing was added
            report["after_esc"] = names()
            report["workers_after_esc"] = workers()
            report["invoke_rock"] = op("fractal_rock")
            state["t"] = now
            return 1.0
        if s == 3:
            if workers() or ("Fractal Rock" not in names() and now - state["t"] < 20):
                state["step"] = 3  # the mesh is still being handed over: look again
                return 0.2
            report["after_rock"] = names()
            report["workers_after_rock"] = workers()
            with bpy.context.temp_override(window=win, area=area):
                bpy.ops.ed.undo()
            report["after_undo"] = names()
    except Exception as e:  # reported, then quit
        import traceback
        report["errors"].append(traceback.format_exc())
    with open(OUT, "w") as f:
        json.dump(report, f)
    bpy.ops.wm.quit_blender()
    return None


bpy.app.timers.register(tick, first_interval=1.0)
