# SPDX-License-Identifier: Apache-2.0
"""rockvdb.Job: a stage call on one thread, watched and cancelled from another (what the
Blender add-on's modal operators do)."""
import threading
import time

import pytest

import rockvdb
from conftest import assert_bitwise_equal


def test_job_reports_progress_and_cancels_a_call_on_another_thread():
    job = rockvdb.Job()
    out = {}

    def work():
        try:
            with job:
                rockvdb.block_tile(tile_size=8, voxel_size=0.02)
            out["finished"] = True
        except KeyboardInterrupt:
            out["cancelled"] = True

    t = threading.Thread(target=work)
    t.start()
    deadline = time.time() + 60
    while job.progress == 0 and t.is_alive() and time.time() < deadline:
        time.sleep(0.01)
    assert 0 < job.progress < 1 and job.phase
    t0 = time.time()
    job.cancel()
    t.join(10)
    assert not t.is_alive() and out == {"cancelled": True}
    assert time.time() - t0 < 1.0
    assert job.cancelled


def test_a_job_run_to_the_end_gives_the_same_bits_and_full_progress():
    plain, _ = rockvdb.fractal_rock(seed=2, voxel_size=0.02)
    job = rockvdb.Job()
    with job:
        watched, _ = rockvdb.fractal_rock(seed=2, voxel_size=0.02)
    assert job.progress == 1.0 and not job.cancelled
    assert_bitwise_equal(plain, watched)


def test_a_job_cannot_nest_and_leaves_its_thread_on_exit():
    job = rockvdb.Job()
    with job:
        with pytest.raises(ValueError, match="already in a job"):
            with rockvdb.Job():
                pass
    job.cancel()  # after the with block: calls on this thread are no longer tied to it
    grid, _ = rockvdb.fractal_rock(voxel_size=0.05)
    assert grid.activeVoxelCount() > 100
