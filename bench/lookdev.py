#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Issue 35: look-dev speed of the demo's cliff at each quality, beside a plain bake.

Runs samples/01_demo.sh at each quality (default: preview, draft, default) and reads the
cliff stage's time from its summary (`vdb_amplify | vdb_detail`; at preview `vdb_amplify`
alone). Reference, in this run: the same terrain without blocks baked at the same voxel size
(`vdb_primitive expr demo_terrain.json`), the floor of any re-bake of that cliff. Each is the
best of RUNS runs (the 2-core VMs are noisy). Prints a Markdown table: quality, voxel, cliff
time and active voxels, the reference's, their ratio, and the whole demo's time.

usage: /usr/bin/python3 bench/lookdev.py [QUALITY ...] [--runs N]
"""
import os
import re
import subprocess
import sys
import tempfile
import time

from machine import cpu, runs_option  # (bench/ is on sys.path: scripts run from there)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
BUILD = os.environ.get("ROCKVDB_BUILD", os.path.join(ROOT, "build"))
TOOLS = os.path.join(BUILD, "vdbtools")
DEMO = os.path.join(ROOT, "samples", "01_demo.sh")


def demo(quality, out):
    """(voxel size, cliff seconds, cliff active voxels, total seconds) of one demo run."""
    p = subprocess.run(["bash", DEMO, BUILD, out, "--quality", quality],
                       capture_output=True, text=True, check=True)
    voxel = float(re.search(r"\(\w+: ([\d.]+) m voxels\)", p.stderr)[1])
    cliff = re.search(r"cliff \([^)]*\)\s+([\d.]+) s .*?surface (\d+)", p.stderr)
    total = float(re.search(r"total\s+([\d.]+) s", p.stderr)[1])
    return voxel, float(cliff[1]), int(cliff[2]), total


def plain(terrain, voxel, out):
    """Seconds and active voxels of the terrain alone at `voxel`."""
    t0 = time.perf_counter()
    p = subprocess.run([os.path.join(TOOLS, "vdb_primitive"), "expr", terrain, "--voxel-size",
                        str(voxel), "-o", out], capture_output=True, text=True, check=True)
    seconds = time.perf_counter() - t0
    return seconds, int(re.search(r"(\d+) active voxels", p.stderr)[1])


def main(argv):
    runs, argv = runs_option(argv)
    qualities = argv or ["preview", "draft", "default"]
    print(f"look-dev: the demo's cliff, best of {runs} runs, {os.cpu_count()} CPUs, {cpu()}")
    print()
    print("| quality | voxel | cliff stage | active voxels | plain terrain (reference) | ratio | whole demo |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for q in qualities:
            out = os.path.join(tmp, q)
            best = min((demo(q, out) for _ in range(runs)), key=lambda r: r[1])
            voxel, cliff, active, total = best
            ref = min((plain(os.path.join(out, "demo_terrain.json"), voxel,
                             os.path.join(tmp, "plain.vdb")) for _ in range(runs)))
            stage = "amplify" if q == "preview" else "amplify, detail"
            print(f"| {q} | {voxel:g} m | {cliff:.1f} s ({stage}) | {active} | "
                  f"{ref[0]:.2f} s, {ref[1]} voxels | {cliff / ref[0]:.1f}x | {total:.1f} s |")
            sys.stdout.flush()


if __name__ == "__main__":
    main(sys.argv[1:])
