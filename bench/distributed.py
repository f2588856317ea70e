#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Issue 20: the cost of baking in chunks on Dask distributed, beside one process.

Scene: samples/data/canyon.exr amplified with a 10 m equidimensional tile (seed 0) at
--voxel-size VOXEL (default 0.1 m). Reference, in this run: one vdb_amplify process with 2
threads. Chunked: the same arguments with --chunks SPLIT (default 4x2x1: 8 chunks; a terrain's
z-split gives chunks of solid inside that cost nothing, leaving the other half the work) on a LocalCluster of 2 single-thread
workers (rockvdb.distributed: plan, 8 chunk tasks, manifest, streaming merge), the cluster's
start included. Reported: wall times and their ratio, peak RSS of the single bake (wait4) and of
the largest chunk (the manifest's), and the merge's throughput in active voxels per second
beside the bake's. Then, from the measured per-chunk rate, the paper estimate for a 2 km x
300 m cliff at 5 cm on 64 workers.

usage: PYTHONPATH=build/python /usr/bin/python3 bench/distributed.py [VOXEL] [OUT_DIR] [SPLIT]
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from machine import cpu  # (bench/ is on sys.path: scripts run from there)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
BUILD = os.environ.get("ROCKVDB_BUILD", os.path.join(ROOT, "build"))
TOOLS = os.path.join(BUILD, "vdbtools")


def timed(argv):
    t0 = time.monotonic()
    p = subprocess.Popen(argv, stderr=subprocess.PIPE)
    err = p.stderr.read().decode()
    _, status, usage = os.wait4(p.pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(err)
    return time.monotonic() - t0, usage.ru_maxrss * 1024, err


def main():
    voxel = float(sys.argv[1]) if len(sys.argv) > 1 else 0.1
    out = sys.argv[2] if len(sys.argv) > 2 else tempfile.mkdtemp(prefix="rockvdb-dist-")
    split = sys.argv[3] if len(sys.argv) > 3 else "4x2x1"
    os.makedirs(out, exist_ok=True)
    tile = os.path.join(out, "equi.tile")
    if not os.path.exists(tile):
        timed([os.path.join(TOOLS, "vdb_blocks"), "-q", "--voxel-size", "0.1", "--tile", tile,
               "-o", os.path.join(out, "blocks.vdb")])
    args = ["--terrain", os.path.join(ROOT, "samples", "data", "canyon.exr"), "--cell-size", "0.5",
            "--tiles", tile, "--distance-range=-1.5,1", "--voxel-size", repr(voxel)]
    amplify = os.path.join(TOOLS, "vdb_amplify")
    single = os.path.join(out, "single.vdb")
    t_single, rss_single, _ = timed([amplify, "-q", *args, "--threads", "2", "-o", single])
    import pyopenvdb
    active = pyopenvdb.read(single, "surface").activeVoxelCount()

    chunked = os.path.join(out, "chunked.vdb")
    shutil.rmtree(os.path.join(out, "chunks"), ignore_errors=True)  # (a kept one would be reused)
    t_chunked, _, err = timed([amplify, *args, "--chunks", split, "--local-workers", "2",
                               "--keep-chunks", "--chunk-dir", os.path.join(out, "chunks"),
                               "-o", chunked])
    manifest = json.load(open(os.path.join(out, "chunks", "manifest.json")))
    rss_chunk = max(f["peak_rss_bytes"] for f in manifest["files"])
    chunk_seconds = [f["seconds"] for f in manifest["files"]]
    # The merge alone, again from the kept folder (the run above merged once already).
    merged = os.path.join(out, "merged.vdb")
    t_merge, rss_merge, _ = timed([os.path.join(TOOLS, "vdb_merge"), "-q", "--manifest",
                                   os.path.join(out, "chunks", "manifest.json"), "-o", merged])

    print(f"CPU: {cpu()}, {os.cpu_count()} cores; canyon.exr amplified at {voxel} m: "
          f"{active} active voxels in 'surface'")
    print()
    print("| run | wall | ratio | peak RSS (largest process) | RSS ratio |")
    print("|---|---|---|---|---|")
    print(f"| one process, 2 threads (reference) | {t_single:.2f} s | 1.00 | "
          f"{rss_single / 1e6:.0f} MB | 1.00 |")
    t_bake = manifest["bake_seconds"]
    n = manifest["count"]
    print(f"| {n} chunks ({split}), LocalCluster of 2 x 1 thread: cluster start, plan, chunk files "
          f"+ manifest | {t_bake:.2f} s | {t_bake / t_single:.2f} | {rss_chunk / 1e6:.0f} MB "
          f"(largest chunk) | {rss_chunk / rss_single:.2f} |")
    print(f"| the same, merged into one .vdb (the whole run) | {t_chunked:.2f} s | "
          f"{t_chunked / t_single:.2f} | | |")
    print(f"| merge of the {n} chunk files (vdb_merge --manifest) | {t_merge:.2f} s | "
          f"{t_merge / t_single:.2f} | {rss_merge / 1e6:.0f} MB | {rss_merge / rss_single:.2f} |")
    print()
    print(f"throughput: bake {active / t_single / 1e6:.2f} M active voxels/s (2 threads); merge "
          f"{active / t_merge / 1e6:.2f} M active voxels/s (one thread reading chunk files); "
          f"chunk times {min(chunk_seconds):.2f}-{max(chunk_seconds):.2f} s")

    # Paper estimate: a 2 km x 300 m cliff face at 5 cm, with the band voxels per square metre
    # the canyon shows here (its footprint from the plan's box), scaled by (voxel / 5 cm)^2.
    per_chunk_rate = active / sum(chunk_seconds)  # voxels per second per single-thread chunk
    area = 2000.0 * 300.0
    vx, vy, _ = manifest["plan"]["voxels"]
    canyon_area = vx * vy * voxel * voxel
    voxels = active * (area / canyon_area) * (voxel / 0.05) ** 2
    bytes_per_voxel = rss_chunk / max(1.0, active / n)
    chunk_voxels = 2e9 / bytes_per_voxel  # chunks of a 2 GB budget per worker
    chunks = voxels / chunk_voxels
    merge_bytes = rss_merge / active * voxels
    print(f"2 km x 300 m at 5 cm: ~{voxels:.2e} band voxels; at the measured {bytes_per_voxel:.0f} "
          f"B/voxel per chunk, a 2 GB budget makes {chunks:.0f} chunks of {chunk_voxels:.1e} voxels; "
          f"one thread bakes {per_chunk_rate / 1e6:.2f} M voxels/s, so 64 single-thread workers "
          f"take ~{voxels / per_chunk_rate / 64 / 60:.0f} min. Merged into one grid it would need "
          f"~{merge_bytes / 1e9:.0f} GB on one machine (the merge's {rss_merge / active:.0f} B/voxel) "
          f"and ~{voxels / (active / t_merge) / 60:.0f} min: keep such a scene chunked "
          f"(--keep-chunks) and load it chunk by chunk")

if __name__ == "__main__":
    main()
