# SPDX-License-Identifier: Apache-2.0
"""docs/gallery.md's scenes and renders (issue 38 item 5): for every figure of the five papers
that shows a result, a scene of that kind made with the vdb_* tools (most through the numbered
samples) and rendered in headless Blender with Cycles (render.py: the add-on's own import, a
sun and a sky, low samples).
usage (from the repository root, after ./rockvdb.sh build):
  /usr/bin/python3 samples/gallery/make.py BUILD_DIR OUT_DIR [--small] [--only NAME,...] [--docs DIR]
  --small: coarse voxels and 96 x 54 renders at 2 samples (what the test runs)
  --docs docs/gallery: the renders as JPEG for docs/gallery.md
Writes OUT_DIR/gallery_<name>.png per entry, the scenes under OUT_DIR/scenes, and
OUT_DIR/gallery.json (name, paper, figure, title, vdb, png, seconds)."""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
_cli = argparse.ArgumentParser(description="docs/gallery.md's scenes and Cycles renders")
_cli.add_argument("build")
_cli.add_argument("out")
_cli.add_argument("--small", action="store_true", help="coarse voxels, 96 x 54 renders at 2 samples")
_cli.add_argument("--only", default="", help="comma-separated entry names")
_cli.add_argument("--docs", default="", help="also write each render as DOCS/gallery_<name>.jpg (docs/gallery)")
_args = _cli.parse_args()
BUILD, OUT, SMALL = os.path.abspath(_args.build), os.path.abspath(_args.out), _args.small
ONLY = set(_args.only.split(",")) if _args.only else None
SCENES = os.path.join(OUT, "scenes")
B = os.path.join(BUILD, "vdbtools")
os.makedirs(SCENES, exist_ok=True)


def v(default, small):
    """A size: the default, or --small's."""
    return small if SMALL else default


def run(*cmd, **kw):
    subprocess.run([str(c) for c in cmd], check=True, cwd=ROOT, **kw)


def tool(name, *args):
    run(os.path.join(B, name), "-q", *args)


_sampled = set()


def sample(script, *args):
    """Run a numbered sample into the scenes folder, once per run (entries share its scenes;
    a scene left by an earlier run, perhaps at the other size, is never reused)."""
    if (script, args) in _sampled:
        return
    run("bash", os.path.join(ROOT, "samples", script), BUILD, SCENES, *args, stdout=subprocess.DEVNULL)
    _sampled.add((script, args))


def scene(name):
    return os.path.join(SCENES, name)


def write(name, text):
    with open(scene(name), "w") as f:
        f.write(text if isinstance(text, str) else json.dumps(text))
    return scene(name)


def py(code, *args):
    """Python with the built rockvdb module (pyopenvdb grids in and out)."""
    run(sys.executable, "-c", code, *args, env=dict(os.environ, PYTHONPATH=os.path.join(BUILD, "python")))


# ---- the scenes: each returns the .vdb to render ------------------------------------------

def amplified_cliff():
    sample("03_amplify.sh", v(0.1, 0.3))
    return scene("amplify_cliff.vdb")


def block_type(kind):
    def make():
        tool("vdb_blocks", "--type", kind, "--tile-size", 10, "--seed", 7, "--voxel-size", v(0.08, 0.3),
             "-o", scene(f"blocks_{kind}.vdb"))
        return scene(f"blocks_{kind}.vdb")
    return make


def tabular(warp):
    def make():
        out = scene(f"tabular_warp_{warp}.vdb")
        extra = ["--warp-amplitude", 0.15 if warp else 0]
        tool("vdb_blocks", "--type", "tabular", "--tile-size", 10, "--seed", 4, "--voxel-size", v(0.06, 0.3),
             *extra, "-o", out)
        return out
    return make


def arches_with_blocks(kind):
    def make():
        coast = scene("arches_coast.vdb")
        sample("09_arches_coast.sh", v(0.25, 0.5))
        tile = scene(f"coast_{kind}.tile")
        tool("vdb_blocks", "--type", kind, "--tile-size", 8, "--seed", 5, "--voxel-size", 0.25,
             "--tile", tile, "-o", scene(f"coast_{kind}_tile.vdb"))
        out = scene(f"coast_blocks_{kind}.vdb")
        tool("vdb_amplify", "--terrain", coast, "--tiles", tile, "--voxel-size", v(0.2, 0.25), "-o", out)
        return out
    return make


def arches(script, stem):
    def make():
        sample(script, *([] if script == "08_arches.sh" else [v(0.25, 0.5)]))
        return scene(f"{stem}.vdb")
    return make


def rockpile(name, tiles_args, support):
    def make():
        tiles = scene(f"{name}.tiles.vdb")
        tool("vdb_rockpile", "tiles", *tiles_args, "-o", tiles)
        sup = support() if callable(support) else support
        out = scene(f"{name}.vdb")
        tool("vdb_rockpile", "pile", "--tiles", tiles, "--support", sup, "--seed", 3, "-o", out)
        return out
    return make


def rock_sizes_support():
    return write("sizes_support.json", {"type": "box", "center": [0, 0, 0], "size": [3, 3, 0.8]})


def zen_support():
    """Lines and circles of stones (Fig. 22): rings and rows of thin capsules on a plane."""
    kids = []
    for r in (1.0, 1.6, 2.2):
        n = int(2 * math.pi * r / 0.4)
        pts = [[r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n), 0.0] for k in range(n)]
        kids += [{"type": "capsule", "a": pts[k], "b": pts[(k + 1) % n], "radius": 0.14} for k in range(n)]
    for y in (-3.2, -2.8, 2.8, 3.2):
        kids.append({"type": "capsule", "a": [-3.5, y, 0], "b": [3.5, y, 0], "radius": 0.14})
    return write("zen_support.json", {"type": "union", "children": kids})


def bories_support():
    """A dry-stone hut (Fig. 24): a corbelled dome with a door."""
    return write("bories_support.json", {"type": "difference", "children": [
        {"type": "intersection", "children": [
            {"type": "transform", "scale": [1, 1, 1.3], "child": {"type": "sphere", "radius": 2.0}},
            {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, -1]}]},
        {"type": "transform", "scale": [1, 1, 1.3], "child": {"type": "sphere", "radius": 1.45}},
        {"type": "box", "center": [2.0, 0, 0.6], "size": [1.6, 0.8, 1.2]}]})


def fractal_rock(name, *args):
    def make():
        out = scene(f"{name}.vdb")
        tool("vdb_fractal_rock", "--size", "1.6,1.2,0.9", "--levels", 3, "--seed", 6, "--tilt", 0,
             "--voxel-size", v(0.01, 0.05), *args, "-o", out)
        return out
    return make


def fractal_boulders():
    sample("07_fractal_boulders.sh", v(0.05, 0.25))
    return scene("fractal_scene.vdb")


def coral():
    """A branching coral of capsules (a skeleton-based implicit, Fig. 1), detailed with frames
    and ridges along its own branches."""
    segs, tips = [], [([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.22, 0)]
    rnd = [0.37, 0.81, 0.12, 0.55, 0.93, 0.26, 0.68, 0.44, 0.05, 0.77, 0.31, 0.59, 0.88, 0.19, 0.63]
    k = 0
    while tips:
        p, d, r, depth = tips.pop(0)
        length = 1.0 * (0.85 ** depth)
        q = [p[i] + d[i] * length for i in range(3)]
        segs.append((p, q, r))
        if depth < 4:
            for side in (0, 1):
                # Two children leaning 35-50° apart around the parent, at azimuths a golden
                # angle on from each other, so the branches spread all round.
                a = 0.6 + 0.25 * rnd[k % len(rnd)]
                b = 2.39996 * (k + 1) + math.pi * side
                k += 1
                nd = [d[0] * math.cos(a) + math.sin(a) * math.cos(b), d[1] * math.cos(a) + math.sin(a) * math.sin(b),
                      max(d[2] * math.cos(a), 0.25)]
                n = math.sqrt(sum(c * c for c in nd))
                tips.append((q, [c / n for c in nd], r * 0.8, depth + 1))
    shape = {"type": "union", "smooth": 0.08,
             "children": [{"type": "capsule", "a": a, "b": b, "radius": r} for a, b, r in segs]}
    skeleton = {"segments": [{"a": a, "b": b, "radius": 4 * r + 0.2, "amplitude": round(0.05 * r, 4)}
                             for a, b, r in segs]}
    plain, out = scene("coral_plain.vdb"), scene("coral.vdb")
    tool("vdb_primitive", "expr", write("coral.json", shape), "--voxel-size", v(0.01, 0.04), "-o", plain)
    tool("vdb_detail", plain, "--gabor-amplitude", 0, "--warp-amplitude", 0, "--gabor-orientation", 90, "--gabor-bandwidth", v(6, 3),
         "--direction-skeleton", write("coral_skeleton.json", skeleton), "--seed", 1, "-o", out)
    return out


def detail_blend():
    """Smooth changes of the details' direction (Fig. 5): ridges turning from 0° to 90° across a
    sphere through a blend mask (gabor §4)."""
    out = scene("detail_blend.vdb")
    voxel = v(0.015, 0.05)
    tool("vdb_primitive", "sphere", "--radius", 1, "--voxel-size", voxel, "-o", scene("blend_sphere.vdb"))
    py("""
import sys
import numpy as np
import pyopenvdb as vdb
import rockvdb
sphere = rockvdb.read(sys.argv[1])
mask = vdb.FloatGrid(0.0)
mask.name = "weights"
mask.transform = vdb.createLinearTransform(voxelSize=0.05)
w = np.clip((np.arange(-30, 30) * 0.05 + 0.5) / 1.0, 0, 1).astype(np.float32)
mask.copyFromArray(np.ascontiguousarray(np.broadcast_to(w[:, None, None], (60, 60, 60))), ijk=(-30, -30, -30))
g = rockvdb.detail(sphere, gabor_amplitude=0.03, gabor_frequency=float(sys.argv[3]), warp_amplitude=0, direction_axis=(0, 0, 1),
                   blend={"gabor_orientation": 90, "gabor_amplitude": 0.03}, blend_mask=mask)
rockvdb.write(sys.argv[2], [g])
""", scene("blend_sphere.vdb"), out, v(6, 3))
    return out


def ring():
    sample("12_detail_skeleton.sh", v(0.02, 0.04))
    return scene("detail_ring.vdb")


ARCHES = {"2": "#d9c08c", "3": "#7b7068", "4": "#4f4a46"}
# vdb_amplify's material: 0 bare terrain, 1 + the tile's index on its blocks.
AMPLIFY = {"0": "#8c8478", "1": "#b09a80", "2": "#c9b28e"}
# (name, paper, figure, title, make, camera, palette)
ENTRIES = [
    ("p1_fig1", "Implicit blocks", "Fig. 1, 11", "A low-resolution cliff amplified with blocks: equidimensional "
     "at its foot, tabular strata above (`samples/03_amplify.sh`)", amplified_cliff, (-60, 20, 1.3), AMPLIFY),
    ("p1_fig5_equidimensional", "Implicit blocks", "Fig. 5", "Equidimensional block tile", block_type("equidimensional"),
     (30, 25, 0.9), None),
    ("p1_fig5_polyhedral", "Implicit blocks", "Fig. 5", "Polyhedral block tile", block_type("polyhedral"), (30, 25, 0.9), None),
    ("p1_fig5_rhombohedral", "Implicit blocks", "Fig. 5", "Rhombohedral block tile", block_type("rhombohedral"),
     (30, 25, 0.9), None),
    ("p1_fig5_columnar", "Implicit blocks", "Fig. 5", "Columnar block tile", block_type("columnar"), (30, 25, 0.9), None),
    ("p1_fig10_plain", "Implicit blocks", "Fig. 10", "Tabular tile without warping", tabular(False), (30, 20, 1.0), None),
    ("p1_fig10_warped", "Implicit blocks", "Fig. 10", "The same tile after the gradient-based warp (§4.2, 15 cm)", tabular(True),
     (30, 20, 1.0), None),
    ("p1_fig14_tabular", "Implicit blocks", "Fig. 14", "Arches and a sea cliff amplified with tabular blocks",
     arches_with_blocks("tabular"), (20, 20, 1.4), AMPLIFY),
    ("p1_fig14_equidimensional", "Implicit blocks", "Fig. 14", "The same with equidimensional blocks",
     arches_with_blocks("equidimensional"), (20, 20, 1.4), AMPLIFY),
    ("p2_fig1", "Arches", "Fig. 1", "Stone arches over a tunnel along a sea cliff (`samples/09_arches_coast.sh`)",
     arches("09_arches_coast.sh", "arches_coast"), (20, 20, 1.4), ARCHES),
    ("p2_fig11", "Arches", "Fig. 11", "A deep ravine swept with a complex profile (`samples/10_arches_ravine.sh`)",
     arches("10_arches_ravine.sh", "arches_ravine"), (300, 35, 1.8), ARCHES),
    ("p2_fig20", "Arches", "Fig. 20", "Tunnels opened by the bays, seen along the coast (`samples/09_arches_coast.sh`)",
     arches("09_arches_coast.sh", "arches_coast"), (60, 6, 2.2), ARCHES),
    ("p2_fig22", "Arches", "Fig. 22", "A canyon with rocks detached from the cliffs (`samples/11_arches_canyon_collapse.sh`)",
     arches("11_arches_canyon_collapse.sh", "arches_canyon_collapse"), (35, 40, 1.3), ARCHES),
    ("p2_fig23", "Arches", "Fig. 23", "Overhangs and arches of strata (`samples/08_arches.sh`)",
     arches("08_arches.sh", "arches_strata"), (210, 15, 1.3), ARCHES),
    ("p3_fig12", "Rock piles", "Fig. 12", "Rocks of different sizes: g in [1, 3], 1 to 20 seeds per cell",
     rockpile("sizes", ["--n", v(5, 4), "--seeds-per-cell", "1,20", "--g-max", 3, "--cube-size", 1.5, "--seed", 2],
              rock_sizes_support), (30, 35, 1.3), None),
    ("p3_fig22", "Rock piles", "Fig. 22", "A Zen garden: small stones in lines and circles",
     rockpile("zen", ["--n", v(5, 4), "--anisotropy", "2,2,1", "--cube-size", 0.5, "--seed", 8], zen_support),
     (-60, 45, 1.2), None),
    ("p3_fig23", "Rock piles", "Fig. 23", "A meshed object converted into rocks (`samples/data/boulder.obj`)",
     rockpile("statue", ["--n", v(5, 4), "--cube-size", 0.6, "--seed", 9], os.path.join(ROOT, "samples", "data", "boulder.obj")),
     (30, 25, 0.9), None),
    ("p3_fig24", "Rock piles", "Fig. 24", "A borie: a dry-stone hut of flat stones",
     rockpile("bories", ["--n", v(5, 4), "--anisotropy", "5,5,1", "--g-max", 2, "--cube-size", 1.0, "--seed", 4],
              bories_support), (20, 20, 1.2), None),
    ("p4_fig6_smooth", "Fractal rocks", "Fig. 6", "Constant H = 0.9", fractal_rock("h09", "--h-up", 0.9, "--h-down", 0.9,
                                                                                   "--roughness", 0.2), (30, 20, 1.0), None),
    ("p4_fig6_rough", "Fractal rocks", "Fig. 6", "Constant H = 0.1", fractal_rock("h01", "--h-up", 0.1, "--h-down", 0.1,
                                                                                  "--roughness", 0.2), (30, 20, 1.0), None),
    ("p4_fig7", "Fractal rocks", "Fig. 7", "H by the face's angle to the up axis: rough top, smooth bottom",
     fractal_rock("hangle", "--h-up", 0.3, "--h-down", 0.95, "--roughness", 0.2), (30, 5, 1.0), None),
    ("p4_fig8", "Fractal rocks", "Fig. 8", "Boulders and pebbles of 16-way subdivided rocks on a canyon floor "
     "(`samples/07_fractal_boulders.sh`)", fractal_boulders, (35, 35, 1.5), {"4": "#6f6a62", "5": "#b3a58c"}),
    ("p5_fig1", "Gabor details", "Fig. 1", "A branching coral of capsules with ridges along its branches",
     coral, (30, 20, 0.75), None),
    ("p5_fig5", "Gabor details", "Fig. 5", "Smooth change of the details' direction across a blend mask (§4)",
     detail_blend, (90, 10, 1.0), None),
    ("p5_fig7", "Gabor details", "Fig. 7", "Details varying along the skeleton: height and frequency stored on it "
     "(`samples/12_detail_skeleton.sh`)", ring, (200, 40, 1.2), None),
]


def main():
    if not shutil.which("blender"):
        sys.exit("gallery: blender is not installed (./rockvdb.sh build installs it)")
    entries, listed = [], []
    for name, paper, fig, title, make, (az, el, zoom), palette in ENTRIES:
        if ONLY and name not in ONLY:
            continue
        t0 = time.time()
        try:
            vdb = make()
        except subprocess.CalledProcessError as e:  # the tool has printed its own error line
            what = e.cmd[1] if os.path.basename(e.cmd[0]) == "bash" else e.cmd[0]
            sys.exit(f"gallery: {name}: {os.path.basename(what)} failed (exit {e.returncode})")
        entries.append({"name": name, "paper": paper, "figure": fig, "title": title, "vdb": vdb,
                        "png": os.path.join(OUT, f"gallery_{name}.png"), "seconds": round(time.time() - t0, 1)})
        listed.append({"name": name, "vdb": vdb, "azimuth": az, "elevation": el, "zoom": zoom,
                       "palette": palette})
        print(f"gallery: {name} {entries[-1]['seconds']} s", file=sys.stderr)
    with open(os.path.join(OUT, "render_list.json"), "w") as f:
        json.dump(listed, f)
    w, h, spp = v((640, 360, 16), (96, 54, 2))
    env = dict(os.environ, BLENDER_USER_SCRIPTS=os.path.join(BUILD, "blender"),
               PYTHONPATH=os.path.join(BUILD, "python"))
    p = subprocess.run([shutil.which("blender"), "-b", "--factory-startup", "--python",
                        os.path.join(ROOT, "samples", "gallery", "render.py"), "--",
                        os.path.join(OUT, "render_list.json"), OUT, str(w), str(h), str(spp)],
                       cwd=ROOT, env=env, capture_output=True, text=True)
    # (Blender prints a script's traceback on stdout and may still exit 0)
    if p.returncode != 0 or "Traceback" in p.stderr + p.stdout:
        said = (p.stderr + p.stdout).strip().splitlines()
        sys.exit(f"gallery: Blender failed: {[l for l in said if 'Error' in l][-1:] or p.returncode}")
    with open(os.path.join(OUT, "gallery.json"), "w") as f:
        json.dump(entries, f, indent=1)
    if _args.docs:
        from PIL import Image  # python3-pil
        os.makedirs(_args.docs, exist_ok=True)
        for e in entries:
            Image.open(e["png"]).convert("RGB").save(os.path.join(_args.docs, f"gallery_{e['name']}.jpg"),
                                                     quality=85, optimize=True)


if __name__ == "__main__":
    main()
