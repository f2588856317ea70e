# SPDX-License-Identifier: Apache-2.0
"""rockvdb.distributed: bake one stage in chunks on a Dask distributed cluster, then merge.

Every rockvdb field is a pure function of world position, and a bake splits into chunks on
leaf faces (`--chunks AxBxC --chunk i/N`, core/Chunks.h) that `vdb_merge` unites bit for bit.
This module puts those chunks on Dask distributed (a LocalCluster by default, any scheduler
otherwise): one task per chunk runs the stage's own tool with the caller's arguments and its
chunk, and writes the chunk file atomically into a shared chunk folder; a manifest
(parameters, chunk list, per-chunk CRC-32, size, time and peak memory) is written last; then
the chunks are merged into one .vdb (one chunk in memory at a time) that is the single-process
bake, provenance included.

    vdb_amplify ARGS --chunks 4x4x1 --local-workers 2 -o out.vdb          # the tools exec this
    /usr/bin/python3 -m rockvdb.distributed --tool vdb_amplify --local-workers 2 \\
        --output out.vdb -- ARGS

    import rockvdb.distributed as rd
    rd.bake("vdb_amplify", ARGS, "out.vdb", chunks="4x4x1", local_workers=2)

Faults: a chunk whose worker dies is run again elsewhere (the scheduler's retries); a chunk is
finished only when its file matches the CRC-32 in its record (chunk_NNNNN.json, written after
the file), so a rerun with the same chunk folder recomputes only chunks that are missing or
damaged, and reuses the rest. The chunk folder is removed after a successful merge unless
keep_chunks; `vdb_merge --manifest DIR/manifest.json -o OUT` merges a kept one again.
"""
import argparse
import hashlib
import json
import logging
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

FORMAT = "rockvdb-chunks"
VERSION = 1


class ChunkError(RuntimeError):
    """A chunk's tool run failed (its message is the tool's own error line, code its exit)."""

    def __init__(self, message, code=1):
        super().__init__(message)
        self.code = code

    def __reduce__(self):  # (raised on a worker, re-raised here: pickled with its code)
        return (ChunkError, (str(self), self.code))


# ---------------------------------------------------------------------------------------------
# One chunk (runs on a worker)

def _die_with_parent():
    # The tool dies with the worker thread that started it (a killed worker leaves no baker
    # behind writing into the chunk folder).
    try:
        import ctypes
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def crc32_of(path):
    """(CRC-32, size) of a file: the checksum vdb_merge --manifest checks (one C++ function,
    core/MergeFiles.h). OSError when unreadable."""
    from . import _rockvdb
    return tuple(_rockvdb.file_checksum(path))


def _write_json(path, value):
    tmp = f"{path}.tmp-{os.getpid()}-{time.monotonic_ns()}"
    with open(tmp, "w") as f:
        json.dump(value, f, indent=1, sort_keys=True)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _run_tool(argv, cwd):
    """Run a tool; (exit code, last stderr line, seconds, peak RSS bytes)."""
    t0 = time.monotonic()
    p = subprocess.Popen(argv, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, preexec_fn=_die_with_parent)
    err = p.stderr.read().decode("utf-8", "replace")
    _, status, usage = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    lines = [l for l in err.splitlines() if l.strip()]
    return p.returncode, (lines[-1] if lines else ""), time.monotonic() - t0, usage.ru_maxrss * 1024


def bake_chunk(tool, args, chunks, index, count, folder, key, threads, cwd):
    """Bake chunk index/count into folder/chunk_NNNNN.vdb and record it; return the record."""
    name = f"chunk_{index:05d}"
    path = os.path.join(folder, name + ".vdb")
    argv = [tool, *args, "--chunks", chunks, "--chunk", f"{index}/{count}", "-q", "-o", path]
    if threads:
        argv += ["--threads", str(threads)]
    code, last, seconds, rss = _run_tool(argv, cwd)
    if code != 0:
        prefix = f"{os.path.basename(tool)}: error: "
        last = last[len(prefix):] if last.startswith(prefix) else last
        raise ChunkError(f"chunk {index}/{count}: {last or f'exit {code}'}", code if code > 0 else 1)
    crc, size = crc32_of(path)
    record = {"index": index, "file": name + ".vdb", "crc32": crc, "bytes": size, "key": key,
              "seconds": round(seconds, 4), "peak_rss_bytes": rss, "host": socket.gethostname(),
              "pid": os.getpid()}
    # After the chunk file: a record whose file matches its CRC-32 is a finished chunk.
    _write_json(os.path.join(folder, name + ".json"), record)
    return record


# ---------------------------------------------------------------------------------------------
# The driver

def _tool_path(tool):
    if os.sep in tool:
        return os.path.abspath(tool)
    here = shutil.which(tool)
    if not here:
        raise ValueError(f"distributed: no tool '{tool}' on PATH")
    return os.path.abspath(here)


def plan(tool, args, chunks=None, chunk_memory=None, count=None, cwd=None):
    """The tool's --plan for these arguments (its whole box, estimates and split) as a dict."""
    argv = [_tool_path(tool), *args, "--plan"]
    if chunks:
        argv += ["--chunks", chunks]
    elif chunk_memory:
        argv += ["--chunk-memory", repr(float(chunk_memory))]
    elif count:
        argv += ["--chunk", f"0/{count}"]
    p = subprocess.run(argv, cwd=cwd, capture_output=True, text=True)
    if p.returncode != 0:
        lines = [l for l in p.stderr.splitlines() if l.strip()]
        raise ValueError(lines[-1] if lines else f"{os.path.basename(tool)} --plan: exit {p.returncode}")
    return json.loads(p.stdout)


def _job_key(tool, args, chunks, count, cwd):
    text = json.dumps({"tool": os.path.basename(tool), "args": list(args), "chunks": chunks,
                       "count": count, "cwd": cwd}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def finished_chunks(folder, key, count):
    """Records of the chunks in folder that are finished for this job (file matches record)."""
    done = {}
    for i in range(count):
        name = os.path.join(folder, f"chunk_{i:05d}")
        try:
            with open(name + ".json") as f:
                rec = json.load(f)
            if rec.get("key") != key or rec.get("index") != i:
                continue
            if crc32_of(name + ".vdb") == (rec["crc32"], rec["bytes"]):
                done[i] = rec
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return done


class _Bar:
    def __init__(self, label, total, quiet):
        self.label, self.total = label, total
        self.on = not quiet and sys.stderr.isatty()
        self.shown = -1

    def show(self, done):
        if not self.on or done == self.shown:
            return
        self.shown = done
        w = 30
        fill = done * w // max(1, self.total)
        sys.stderr.write(f"\r\033[K{self.label}: chunks [{'#' * fill}{' ' * (w - fill)}] "
                         f"{done}/{self.total}")
        sys.stderr.flush()

    def clear(self):
        if self.on and self.shown >= 0:
            sys.stderr.write("\r\033[K")
            sys.stderr.flush()


def _kill_local_cluster(cluster, worker_pids):
    import multiprocessing
    for pid in worker_pids + [c.pid for c in multiprocessing.active_children()]:
        try:
            os.kill(pid, signal.SIGKILL)
        except (ProcessLookupError, TypeError):
            pass


def bake(tool, args, output, chunks=None, chunk_memory=None, client=None, scheduler=None,
         local_workers=None, chunk_dir=None, keep_chunks=False, threads=None, quiet=True,
         merge=True):
    """Bake `tool args` in chunks on a Dask cluster and merge them into output.

    tool: a baking tool (vdb_amplify, vdb_blocks, vdb_detail, vdb_rockpile with 'pile' in
    args); args: its arguments without -o; chunks: "AxBxC", else the fewest chunks whose
    estimated memory fits chunk_memory GB, else 4 per worker; client: a
    dask.distributed.Client, else one for scheduler ("tcp://host:8786"), else a LocalCluster
    of local_workers processes (default 2) on this machine; chunk_dir: the chunk folder
    (default output + ".chunks"; a rerun reuses its finished chunks); threads: per chunk
    (default: cores / workers for a LocalCluster). Returns the manifest (dict), which also
    says which chunks were computed and which reused."""
    from distributed import Client, LocalCluster, as_completed

    t0 = time.monotonic()
    tool = _tool_path(tool)
    args = [os.fspath(a) for a in args]
    label = os.path.basename(tool)
    cwd = os.getcwd()
    if output == "-":
        raise ValueError("distributed: the merged output must be a file (not stdout)")
    output = os.path.abspath(output)
    if not os.path.isdir(os.path.dirname(output)):
        raise ValueError(f"cannot write {output}: no folder {os.path.dirname(output)}")
    folder = os.path.abspath(chunk_dir or output + ".chunks")
    own_cluster, space = None, None
    if client is None:
        if scheduler:
            client = Client(scheduler, timeout="30s")
        else:
            workers = int(local_workers or 2)
            if threads is None:
                threads = max(1, (os.cpu_count() or 1) // workers)
            # A Ctrl-C kills the workers; multiprocessing's resource tracker then frees their
            # semaphores (it is started with this environment) without a warning of its own.
            warn = os.environ.get("PYTHONWARNINGS", "")
            os.environ["PYTHONWARNINGS"] = ",".join(
                filter(None, [warn, "ignore::UserWarning:multiprocessing.resource_tracker"]))
            # Dask's own log lines stay off stderr while our cluster runs (a failed chunk is
            # reported once, here; a Ctrl-C kills the workers, which their nannies would log
            # as "Restarting worker", and a worker closed mid-heartbeat logs an ERROR "Scheduler
            # was unaware of this worker"; what matters reaches this process as an exception).
            # The workers configure their logging from Dask's config, which they are started
            # with; this process configured its loggers when it imported Dask, so their levels
            # are set here.
            os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "critical")
            import dask
            dask.config.refresh()
            dask_logs = [logging.getLogger(n) for n in ("distributed", "distributed.client")]
            dask_levels = [log.level for log in dask_logs]
            for log in dask_logs:
                log.setLevel(logging.CRITICAL)
            space = tempfile.mkdtemp(prefix="rockvdb-dask-")
            own_cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       dashboard_address=":0", host="127.0.0.1",
                                       local_directory=space)
            client = Client(own_cluster)
    local_pids = list(client.run(os.getpid).values()) if own_cluster is not None else []
    try:
        workers = max(1, len(client.scheduler_info().get("workers", {})))
        count_hint = None if (chunks or chunk_memory) else 4 * workers
        p = plan(tool, args, chunks=chunks, chunk_memory=chunk_memory, count=count_hint, cwd=cwd)
        dims, count = p["chunks"], int(p["count"])
        key = _job_key(tool, args, dims, count, cwd)
        made_folder = not os.path.isdir(folder)
        os.makedirs(folder, exist_ok=True)
        done = finished_chunks(folder, key, count)
        todo = [i for i in range(count) if i not in done]
        bar = _Bar(label, count, quiet)
        bar.show(len(done))
        futures = [client.submit(bake_chunk, tool, args, dims, i, count, folder, key, threads,
                                 cwd, key=f"rockvdb-chunk-{key}-{i}", pure=False) for i in todo]
        records = dict(done)
        try:
            for fut in as_completed(futures):
                rec = fut.result()
                records[rec["index"]] = rec
                bar.show(len(records))
        except BaseException as e:
            bar.clear()
            if own_cluster is not None and isinstance(e, KeyboardInterrupt):
                # Ctrl-C: stop at once. The workers (and, by PDEATHSIG, the bakers they run)
                # are killed rather than shut down politely (that takes seconds).
                _kill_local_cluster(own_cluster, local_pids)
                shutil.rmtree(space, ignore_errors=True)
                own_cluster = None
            else:
                client.cancel(futures)
            if made_folder and not any(n.endswith(".json") for n in os.listdir(folder)):
                # No finished chunk to keep for a rerun: the new chunk folder goes too.
                shutil.rmtree(folder, ignore_errors=True)
            raise
        bar.clear()
        bake_seconds = time.monotonic() - t0
        manifest = {"format": FORMAT, "version": VERSION, "tool": label, "args": args, "cwd": cwd,
                    "chunks": dims, "count": count, "key": key, "plan": p,
                    "files": [records[i] for i in range(count)],
                    "computed": todo, "reused": sorted(done), "workers": workers,
                    "bake_seconds": round(bake_seconds, 4)}
        _write_json(os.path.join(folder, "manifest.json"), manifest)
    finally:
        if own_cluster is not None:
            client.close()
            own_cluster.close()
            shutil.rmtree(space, ignore_errors=True)
            for log, level in zip(dask_logs, dask_levels):
                log.setLevel(level)
    if merge:
        t1 = time.monotonic()
        merge_tool = os.path.join(os.path.dirname(tool), "vdb_merge")
        argv = [merge_tool, "--manifest", os.path.join(folder, "manifest.json"), "-o", output]
        if quiet:
            argv.append("-q")
        r = subprocess.run(argv, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            lines = [l for l in r.stderr.splitlines() if l.strip()]
            raise ChunkError(lines[-1] if lines else f"vdb_merge: exit {r.returncode}", r.returncode)
        if r.stderr and not quiet:
            sys.stderr.write(r.stderr)
        manifest["merge_seconds"] = round(time.monotonic() - t1, 4)
        if not keep_chunks:
            shutil.rmtree(folder, ignore_errors=True)
    if not quiet:
        rss = max((r["peak_rss_bytes"] for r in manifest["files"] if r["index"] in todo), default=0)
        sys.stderr.write(f"{label}: {count} chunks ({dims}): {len(todo)} baked, {len(done)} reused, "
                         f"on {workers} workers in {bake_seconds:.3f} s (peak {rss / 1e6:.0f} MB "
                         f"per chunk)" + (f"; merge {manifest['merge_seconds']:.3f} s" if merge else "")
                         + "\n")
    return manifest


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m rockvdb.distributed",
                                 description="Bake a rockvdb tool's run in chunks on Dask "
                                             "distributed, then merge (the tools' --local-workers "
                                             "/ --scheduler call this).")
    ap.add_argument("--tool", required=True, help="the baking tool (path or name on PATH)")
    ap.add_argument("--output", "-o", required=True, help="merged .vdb")
    ap.add_argument("--local-workers", type=int, default=None)
    ap.add_argument("--scheduler", default=None)
    ap.add_argument("--chunks", default=None)
    ap.add_argument("--chunk-memory", type=float, default=None, help="GB per chunk")
    ap.add_argument("--chunk-dir", default=None)
    ap.add_argument("--keep-chunks", action="store_true")
    ap.add_argument("--quiet", "-q", action="store_true")
    ap.add_argument("args", nargs=argparse.REMAINDER)
    a = ap.parse_args(argv)
    args = a.args[1:] if a.args[:1] == ["--"] else a.args
    label = os.path.basename(a.tool)
    threads = None
    for i, w in enumerate(args):
        if w == "--threads" and i + 1 < len(args):
            threads = int(args[i + 1])
        elif w.startswith("--threads="):
            threads = int(w.split("=", 1)[1])
    args = [w for i, w in enumerate(args)
            if not (w == "--threads" or w.startswith("--threads=") or
                    (i > 0 and args[i - 1] == "--threads"))]
    quiet = a.quiet or "-q" in args or "--quiet" in args
    # Like the tools: Ctrl-C and SIGTERM stop the run (also when started with SIGINT ignored,
    # as a shell's background job is).
    def interrupt(*_):
        raise KeyboardInterrupt()
    signal.signal(signal.SIGINT, interrupt)
    signal.signal(signal.SIGTERM, interrupt)
    try:
        bake(a.tool, args, a.output, chunks=a.chunks, chunk_memory=a.chunk_memory,
             scheduler=a.scheduler, local_workers=a.local_workers, chunk_dir=a.chunk_dir,
             keep_chunks=a.keep_chunks, threads=threads, quiet=quiet)
    except KeyboardInterrupt:
        sys.stderr.write(f"{label}: error: interrupted; nothing written (finished chunks are kept "
                         f"for a rerun)\n")
        sys.stderr.flush()
        os._exit(130)  # (no waiting for the cluster's threads)
    except (ValueError, ChunkError, OSError) as e:
        msg = str(e).replace("\n", " ")
        if not msg.startswith(label):
            msg = f"{label}: error: {msg}"
        sys.stderr.write(msg + "\n")
        return e.code if isinstance(e, ChunkError) else 2 if isinstance(e, ValueError) else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
