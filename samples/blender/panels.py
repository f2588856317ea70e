# SPDX-License-Identifier: Apache-2.0
"""docs/blender.md's panel pictures: Blender with a window (under Xvfb), each rockvdb operator
run at its defaults as from the menu, then its redo panel (F9) opened and the window captured,
and the sidebar's rockvdb tab with a result selected.
usage (from the repository root, after ./rockvdb.sh build):
  BLENDER_USER_SCRIPTS=$PWD/build/blender PYTHONPATH=$PWD/build/python xvfb-run -a \\
      -s "-screen 0 1600x1000x24" blender --factory-startup --enable-event-simulate \\
      --python samples/blender/panels.py -- OUT_DIR
Writes OUT_DIR/panel_<operator>.png (the redo panel over the result, 700 x 700 of the window),
OUT_DIR/panel_block_tile_fractures.png (its Fractures group open: the Auto rows) and
OUT_DIR/sidebar.png (the sidebar's tab)."""
import os
import sys
import traceback

import addon_utils
import bpy

OUT = sys.argv[sys.argv.index("--") + 1]
os.makedirs(OUT, exist_ok=True)
addon_utils.enable("rockvdb_blender", default_set=True)
win = bpy.context.window_manager.windows[0]
area = next(a for a in win.screen.areas if a.type == "VIEW_3D")
region = next(r for r in area.regions if r.type == "WINDOW")


def ctx():
    return bpy.context.temp_override(window=win, area=area, region=region)


def setup(stage):
    """The scene an artist would start each operator from."""
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    with ctx():
        if stage in ("amplify", "stacks", "fractal_scatter"):
            bpy.ops.mesh.primitive_grid_add(size=10, x_subdivisions=10, y_subdivisions=10,
                                            location=(6, 6, 0))
            bpy.context.active_object.data.vertices[60].co.z = 3.0
            if stage == "amplify":
                sheet = bpy.context.active_object
                bpy.ops.rockvdb.block_tile()
                bpy.context.view_layer.objects.active = sheet
        elif stage == "rock_pile":
            bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0, 0, 1))
        elif stage == "detail":
            bpy.ops.rockvdb.fractal_rock()


# (operator, its properties, picture name)
RUNS = [(s, {}, s) for s in ("fractal_rock", "fractal_scatter", "block_tile", "rock_pile",
                             "amplify", "stacks", "detail")]
RUNS.append(("block_tile", {"show_shape": False, "show_fractures": True}, "block_tile_fractures"))
steps = [("splash", None)]
for s in RUNS:
    steps += [("run", s), ("wait", s), ("panel", s), ("shot", s), ("close", s)]
steps += [("sidebar", None), ("shot", "sidebar"), ("quit", None)]


def tick():
    try:
        kind, stage = steps.pop(0)
        if kind == "splash":  # the first-start splash of --factory-startup
            win.event_simulate(type="ESC", value="PRESS", x=100, y=500)
            win.event_simulate(type="ESC", value="RELEASE", x=100, y=500)
        elif kind == "run":  # as from the menu: modal, the stage on its worker
            op, props, _ = stage
            setup(op)
            with ctx():
                getattr(bpy.ops.rockvdb, op)("INVOKE_DEFAULT", **props)
        elif kind == "wait":
            made = [o for o in bpy.data.objects if o.get("rockvdb_stage") == stage[0]]
            if not made:
                steps.insert(0, (kind, stage))
                return 0.5
            with ctx():
                bpy.ops.view3d.view_all(center=False)
        elif kind == "panel":
            # F9 with the pointer at the viewport's left: the redo panel as a popup
            win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=330, y=300)
            win.event_simulate(type="F9", value="PRESS", x=330, y=300)
            win.event_simulate(type="F9", value="RELEASE", x=330, y=300)
        elif kind == "close":
            win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=700, y=500)
            win.event_simulate(type="ESC", value="PRESS", x=700, y=500)
            win.event_simulate(type="ESC", value="RELEASE", x=700, y=500)
        elif kind == "sidebar":  # N, then a click on the sidebar's rockvdb tab
            area.spaces[0].show_region_ui = True
            ui = next(r for r in area.regions if r.type == "UI")
            steps.insert(0, ("tab", ui))
        elif kind == "tab":
            ui = stage
            # the tabs stand at the region's right edge; rockvdb's is the fourth (Item, Tool,
            # View, rockvdb), about 75 pixels below the top of the third
            x, y = ui.x + ui.width - 8, win.height - 250
            print("sidebar region", ui.x, ui.y, ui.width, ui.height, "click", x, y)
            win.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
            win.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y)
            win.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y)
        elif kind == "shot":
            from PIL import Image  # python3-pil
            name = "sidebar" if stage == "sidebar" else f"panel_{stage[2]}"
            path = os.path.join(OUT, name + ".png")
            with ctx():
                bpy.ops.screen.screenshot(filepath=path)
            # (the popup opens at the pointer, 330 px from the left; the sidebar's tab)
            box = (1050, 60, 1330, 700) if stage == "sidebar" else (300, 300, 1000, 1000)
            Image.open(path).convert("RGB").crop(box).save(path, optimize=True)
        elif kind == "quit":
            bpy.ops.wm.quit_blender()
            return None
    except Exception:
        traceback.print_exc()
    return 1.0


bpy.app.timers.register(tick, first_interval=2.0)
