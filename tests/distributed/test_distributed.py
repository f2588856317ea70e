# SPDX-License-Identifier: Apache-2.0
"""Chunked bakes on Dask distributed (rockvdb.distributed, issue 20), loopback only: a
LocalCluster of 2 worker processes. Every distributed result is compared with the single-process
bake of the same arguments: every grid, its leaves, active voxels, values over the active box
(inside fill included) bit for bit, and its provenance (a merged file replays as one bake)."""
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from conftest import BUILD, dense, one_line_error, run, tool

import pyopenvdb as vdb

sys.path.insert(0, os.path.join(BUILD, "python"))
import rockvdb.distributed as rd  # noqa: E402

SAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "samples", "data")


def assert_same_file(a, b):
    ga, gb = vdb.readAll(str(a))[0], vdb.readAll(str(b))[0]
    assert [g.name for g in ga] == [g.name for g in gb]
    for x, y in zip(ga, gb):
        assert x.leafCount() == y.leafCount(), x.name
        assert x.activeVoxelCount() == y.activeVoxelCount(), x.name
        assert x.background == y.background and x.gridClass == y.gridClass
        (ba, da), (bb, db) = dense(x), dense(y)
        assert ba == bb, x.name
        assert np.array_equal(da.view(np.uint32), db.view(np.uint32)), x.name
        for k in ("rockvdb:generator", "rockvdb:params"):
            assert x.metadata[k] == y.metadata[k], (x.name, k)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("scene")
    tile = d / "equi.tile"
    run([tool("vdb_blocks"), "-q", "--voxel-size", "0.1", "--tile", str(tile), "-o",
         str(d / "blocks.vdb")], check=True)
    amplify = ["--terrain", os.path.join(SAMPLES, "canyon.exr"), "--cell-size", "0.5", "--tiles",
               str(tile), "--distance-range=-1.5,1", "--voxel-size", "0.2"]
    whole = d / "amplify_whole.vdb"
    run([tool("vdb_amplify"), "-q", *amplify, "-o", str(whole)], check=True)
    tiles = d / "rocks.tiles.vdb"
    run([tool("vdb_rockpile"), "tiles", "-q", "--n", "4", "--voxels-per-cell", "6", "--seed", "3",
         "-o", str(tiles)], check=True)
    support = d / "mound.json"
    support.write_text(json.dumps({"type": "sphere", "center": [0.2, 0.1, -0.3], "radius": 1.4}))
    pile = ["pile", "--tiles", str(tiles), "--support", str(support), "--material", "4"]
    pile_whole = d / "pile_whole.vdb"
    run([tool("vdb_rockpile"), "-q", *pile, "-o", str(pile_whole)], check=True)
    return {"dir": d, "amplify": amplify, "amplify_whole": whole, "pile": pile,
            "pile_whole": pile_whole}


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=":0", host="127.0.0.1")
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_amplify_in_eight_chunks_on_a_local_cluster_is_the_single_bake(scene, tmp_path):
    """The tool's own flags: --chunks 2x2x2 --local-workers 2 execs rockvdb.distributed."""
    out = tmp_path / "dist.vdb"
    p = run([tool("vdb_amplify"), *scene["amplify"], "--chunks", "2x2x2", "--local-workers", "2",
             "-o", str(out)])
    assert p.returncode == 0, p.stderr
    assert "8 chunks (2x2x2): 8 baked, 0 reused, on 2 workers" in p.stderr
    assert_same_file(out, scene["amplify_whole"])
    assert not os.path.exists(str(out) + ".chunks")  # removed after the merge


def test_a_rock_pile_in_eight_chunks_is_the_single_bake(scene, tmp_path, client):
    out = tmp_path / "pile.vdb"
    m = rd.bake(tool("vdb_rockpile"), scene["pile"], out, chunks="2x2x2", client=client,
                keep_chunks=True)
    assert m["count"] == 8 and m["computed"] == list(range(8))
    # Rocks straddle the chunk faces: several chunks hold voxels of one rock.
    sizes = [f["bytes"] for f in m["files"]]
    assert min(sizes) > 0
    assert_same_file(out, scene["pile_whole"])
    # The kept chunk folder merges again through vdb_merge --manifest.
    again = tmp_path / "again.vdb"
    p = run([tool("vdb_merge"), "-q", "--manifest", str(out) + ".chunks/manifest.json", "-o", str(again)])
    assert p.returncode == 0, p.stderr
    assert_same_file(again, scene["pile_whole"])


def test_resume_recomputes_exactly_the_missing_and_damaged_chunks(scene, tmp_path, client):
    out, folder = tmp_path / "r.vdb", tmp_path / "chunks"
    m = rd.bake(tool("vdb_amplify"), scene["amplify"], out, chunks="2x2x2", client=client,
                chunk_dir=folder, keep_chunks=True)
    assert m["computed"] == list(range(8)) and m["reused"] == []
    os.remove(folder / "chunk_00001.vdb")
    os.remove(folder / "chunk_00006.vdb")
    damaged = folder / "chunk_00004.vdb"
    data = bytearray(damaged.read_bytes())
    data[len(data) // 2] ^= 0x40
    damaged.write_bytes(bytes(data))
    # vdb_merge names the damaged chunk and writes nothing.
    bad = tmp_path / "bad.vdb"
    p = run([tool("vdb_merge"), "-q", "--manifest", str(folder / "manifest.json"), "-o", str(bad)])
    one_line_error(p, 1, "chunk 1/8", "missing")
    assert not bad.exists()
    os.remove(out)
    # The rerun from the CLI, on the running cluster by its scheduler's address.
    p = run([tool("vdb_amplify"), *scene["amplify"], "--chunks", "2x2x2", "--scheduler",
             client.scheduler.address, "--chunk-dir", str(folder), "--keep-chunks", "-o", str(out)])
    assert p.returncode == 0, p.stderr
    assert "3 baked, 5 reused" in p.stderr
    m = json.load(open(folder / "manifest.json"))
    assert m["computed"] == [1, 4, 6] and m["reused"] == [0, 2, 3, 5, 7]
    assert_same_file(out, scene["amplify_whole"])


def test_a_killed_worker_is_replaced_and_the_bits_are_the_same(scene, tmp_path, client):
    """A worker process is killed (SIGKILL) while chunks run; the scheduler runs its chunk on
    another worker, and the baker the dead worker had started dies with it (PDEATHSIG)."""
    out, folder = tmp_path / "k.vdb", tmp_path / "chunks"
    pids = client.run(os.getpid)
    killed, bakers = [], []

    def children_of(pid):
        out = []
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                try:
                    stat = open(f"/proc/{entry}/stat").read()
                except OSError:
                    continue
                if int(stat.rsplit(")", 1)[1].split()[1]) == pid and "(vdb_" in stat:
                    out.append(int(entry))  # the chunk's tool (not a helper Dask started)
        return out

    def killer():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            busy = client.processing()
            for addr, keys in busy.items():
                if keys and addr in pids and not killed:
                    # Wait for the chunk's tool to start (a loaded machine may take a while),
                    # then kill its worker.
                    until = time.monotonic() + 20
                    while not bakers and time.monotonic() < until:
                        time.sleep(0.05)
                        bakers.extend(children_of(pids[addr]))
                    os.kill(pids[addr], signal.SIGKILL)
                    killed.append(pids[addr])
                    return
            time.sleep(0.05)

    t = threading.Thread(target=killer)
    t.start()
    m = rd.bake(tool("vdb_amplify"), scene["amplify"], out, chunks="4x2x2", client=client,
                chunk_dir=folder, keep_chunks=True)
    t.join()
    assert killed, "no worker was busy"
    assert m["count"] == 16 and sorted(m["computed"]) == list(range(16))
    with pytest.raises(ProcessLookupError):
        os.kill(killed[0], 0)
    # The dead worker's baker died with it (PR_SET_PDEATHSIG), not left baking as an orphan.
    assert bakers, "the killed worker had no baker running"
    def running(pid):  # a zombie waiting for its new parent to reap it counts as dead
        try:
            return open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0] != "Z"
        except OSError:
            return False

    assert not [b for b in bakers if running(b)]
    assert_same_file(out, scene["amplify_whole"])
    client.wait_for_workers(2, timeout=60)


def test_chunk_i_of_n_as_separate_processes_then_merged_is_the_whole_bake(scene, tmp_path):
    """A farm's job array: N processes, each --chunk i/N (the split chosen for N alone), then
    vdb_merge; the result carries the whole bake's provenance and replays to it."""
    files = []
    procs = []
    for i in range(6):
        f = tmp_path / f"c{i}.vdb"
        files.append(str(f))
        procs.append(subprocess.Popen([tool("vdb_amplify"), "-q", *scene["amplify"], "--chunk",
                                       f"{i}/6", "--threads", "1", "-o", str(f)],
                                      stderr=subprocess.PIPE))
    for p in procs:
        assert p.wait(timeout=300) == 0, p.stderr.read()
    merged = tmp_path / "merged.vdb"
    p = run([tool("vdb_merge"), "-q", *files, "-o", str(merged)])
    assert p.returncode == 0, p.stderr
    assert_same_file(merged, scene["amplify_whole"])
    # A missing chunk is named, nothing is written.
    partial = tmp_path / "partial.vdb"
    p = run([tool("vdb_merge"), "-q", *files[:4], "-o", str(partial)])
    one_line_error(p, 2, "4 of the 6 chunks", "missing chunk(s) 4, 5")
    assert not partial.exists()


def test_plan_reports_the_split_a_memory_budget_needs(scene):
    p = run([tool("vdb_amplify"), *scene["amplify"], "--plan"])
    assert p.returncode == 0, p.stderr
    whole = json.loads(p.stdout)
    assert whole["count"] == 1 and whole["chunks"] == "1x1x1" and whole["bytes"] > 0
    budget = whole["bytes"] / 3.5 / 1e9
    p = run([tool("vdb_amplify"), *scene["amplify"], "--plan", "--chunk-memory", repr(budget)])
    plan = json.loads(p.stdout)
    assert plan["box"] == whole["box"]
    assert plan["chunk_bytes"] <= budget * 1e9 and plan["count"] >= 4
    a, b, c = (int(x) for x in plan["chunks"].split("x"))
    assert a * b * c == plan["count"]


@pytest.mark.parametrize("args, code, needles", [
    (["--chunk", "8/8"], 2, ["chunk must be i/N", "8/8"]),
    (["--chunks", "2x2", "--chunk", "0/4"], 2, ["chunks must be AxBxC", "2x2"]),
    (["--chunks", "2x2x2", "--chunk", "1/4"], 2, ["counts 4 chunks", "makes 8"]),
    (["--chunk-memory", "1"], 2, ["--chunk-memory", "cluster run"]),
    (["--local-workers", "2", "--chunk", "1/4"], 2, ["--chunk names one chunk"]),
    (["--local-workers", "0"], 2, ["--local-workers"]),
])
def test_bad_chunk_arguments_are_one_line_and_write_nothing(scene, tmp_path, args, code, needles):
    out = tmp_path / "o.vdb"
    out.write_bytes(b"keep")
    p = run([tool("vdb_amplify"), *scene["amplify"], *args, "-o", str(out)])
    one_line_error(p, code, *needles)
    assert out.read_bytes() == b"keep"


def test_python_and_cli_bake_the_same_chunk(scene, tmp_path):
    """The chunk rows come from the stage's table: rockvdb.rock_pile(chunks=, chunk=) is the
    CLI's chunk, bit for bit."""
    import rockvdb
    cli = tmp_path / "c.vdb"
    run([tool("vdb_rockpile"), "-q", *scene["pile"], "--chunks", "2x1x1", "--chunk", "1/2", "-o",
         str(cli)], check=True)
    grids = rockvdb.rock_pile(scene["pile"][2], scene["pile"][4], material=4, chunks="2x1x1",
                              chunk="1/2")
    mine = {g.name: g for g in grids}
    for g in vdb.readAll(str(cli))[0]:
        (ba, da), (bb, db) = dense(g), dense(mine[g.name])
        assert ba == bb and np.array_equal(da.view(np.uint32), db.view(np.uint32)), g.name


def test_ctrl_c_stops_the_cluster_run_at_once_and_a_rerun_keeps_its_finished_chunks(scene, tmp_path):
    out, folder = tmp_path / "i.vdb", tmp_path / "chunks"
    argv = [tool("vdb_amplify"), *scene["amplify"], "--chunks", "4x2x2", "--local-workers", "2",
            "--chunk-dir", str(folder), "-o", str(out)]
    p = subprocess.Popen(argv, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not list(folder.glob("chunk_*.json")) and time.monotonic() < deadline:
        assert p.poll() is None, p.stderr.read()
        time.sleep(0.05)
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    err = p.communicate(timeout=30)[1].decode()
    assert p.returncode == 130 and time.monotonic() - t0 < 1.5, (p.returncode, err)
    lines = [l for l in err.splitlines() if l.strip()]
    assert len(lines) == 1 and "interrupted" in lines[0], err
    assert not out.exists()
    kept = len(list(folder.glob("chunk_*.json")))
    assert 1 <= kept < 16
    p = run(argv)
    assert p.returncode == 0, p.stderr
    assert f"{16 - kept} baked, {kept} reused" in p.stderr
    assert_same_file(out, scene["amplify_whole"])


@pytest.mark.parametrize("stage", ["blocks", "detail", "pile", "arches"])
def test_every_baking_stage_chunks_to_its_single_bake(scene, tmp_path, stage):
    """Block tiles over periods, surface detail on a level set, a rock pile and a
    material-stack ground (its level sets, 'material' and the weight grids; cut on the
    redistance's 128-voxel sweep tiles), each as --chunk i/N processes (splits given and
    chosen) merged by vdb_merge."""
    if stage == "arches":
        from conftest import arches_small_scene
        base = [tool("vdb_arches"), "-q", str(arches_small_scene(tmp_path)), "--voxel-size", "0.08"]
        split, n = ["--chunks", "2x1x1"], 2
    elif stage == "blocks":
        base = [tool("vdb_blocks"), "-q", "--voxel-size", "0.1", "--periods", "2,2,1"]
        split, n = ["--chunks", "2x2x1"], 4
    elif stage == "detail":
        ball = tmp_path / "ball.vdb"
        run([tool("vdb_primitive"), "-q", "sphere", "--radius", "1.5", "--voxel-size", "0.03", "-o",
             str(ball)], check=True)
        base, split, n = [tool("vdb_detail"), "-q", str(ball)], [], 6
    else:
        base, split, n = [tool("vdb_rockpile"), "-q", *scene["pile"]], ["--chunks", "1x3x1"], 3
    whole = tmp_path / "whole.vdb"
    run([*base, "-o", str(whole)], check=True)
    parts = []
    for i in range(n):
        parts.append(str(tmp_path / f"part{i}.vdb"))
        run([*base, *split, "--chunk", f"{i}/{n}", "-o", parts[-1]], check=True)
    merged = tmp_path / "merged.vdb"
    run([tool("vdb_merge"), "-q", *parts, "-o", str(merged)], check=True)
    assert_same_file(merged, whole)
    # Each chunk holds part of the whole, not all of it.
    counts = [vdb.read(p, "surface").activeVoxelCount() for p in parts]
    assert max(counts) < vdb.read(str(whole), "surface").activeVoxelCount()


def test_arches_with_rock_tiles_refuses_a_chunk(scene, tmp_path):
    """Rocks are chosen over the whole rock layers: a chunk of them is refused in one line."""
    from conftest import arches_small_scene
    path = arches_small_scene(tmp_path, **{"rock-tiles": str(scene["dir"] / "rocks.tiles.vdb")})
    out = tmp_path / "o.vdb"
    p = run([tool("vdb_arches"), "-q", str(path), "--chunk", "0/2", "-o", str(out)])
    one_line_error(p, 2, "rock tiles", "without --chunk")
    assert not out.exists()


def test_a_failing_chunk_is_one_line_with_its_tools_exit_code(tmp_path):
    """Every chunk of vdb_blocks --tile fails (the tile describes the whole run): the cluster
    run says so once, with the tool's code, and writes nothing, not even an empty chunk folder
    (no chunk finished). The output given as CLI11's -oFILE is the driver's, not the chunks'
    (each chunk once got it beside its own -o)."""
    out, tile = tmp_path / "b.vdb", tmp_path / "t.tile"
    p = run([tool("vdb_blocks"), "--voxel-size", "0.2", "--tile", str(tile), "--chunks", "2x1x1",
             "--local-workers", "2", f"-o{out}"])
    one_line_error(p, 2, "chunk", "--tile describes the whole tile")
    assert not out.exists() and not tile.exists()
    assert os.listdir(tmp_path) == [], os.listdir(tmp_path)
    p = run([tool("vdb_blocks"), "--voxel-size", "0.2", "--chunks", "2x1x1", "--local-workers",
             "2", "-o", str(tmp_path / "no" / "b.vdb")])
    one_line_error(p, 2, "no folder")
    assert not (tmp_path / "no").exists()
