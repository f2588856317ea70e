# SPDX-License-Identifier: Apache-2.0
"""Build flags that decide speed and determinism, read from the build's compile_commands.json:
CGAL's -frounding-math stays on the hull's source (it slows every floating-point loop it
reaches), and the ops sources keep the determinism flags (no FMA contraction)."""
import json
import os

import pytest

BUILD = os.environ.get("ROCKVDB_BUILD", "build")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(scope="module")
def commands():
    path = os.path.join(BUILD, "compile_commands.json")
    with open(path) as f:
        entries = json.load(f)
    by_file = {}
    for e in entries:
        rel = os.path.relpath(os.path.realpath(e["file"]), os.path.realpath(ROOT))
        by_file[rel] = e.get("command") or " ".join(e.get("arguments", []))
    return by_file


def test_only_the_hull_compiles_with_rounding_math(commands):
    ours = {f: c for f, c in commands.items() if not f.startswith("..")}
    assert len(ours) > 40, sorted(ours)
    rounding = sorted(f for f, c in ours.items() if "-frounding-math" in c.split())
    assert rounding == ["ops/blocks/Hull.cc"], rounding


def test_ops_sources_keep_the_determinism_flags(commands):
    ops = {f: c for f, c in commands.items() if f.startswith("ops/")}
    assert "ops/core/Bake.cc" in ops and "ops/blocks/Hull.cc" in ops
    for f, c in ops.items():
        flags = c.split()
        assert "-ffp-contract=off" in flags, f
        assert not any(x.startswith("-march") for x in flags), f


# Each folder of ops/ is one library; a layer includes only the layers below it.
LAYERS = {"core": set(), "relief": {"core"}, "blocks": {"core", "relief"},
          "amplify": {"core", "relief", "blocks"}, "detail": {"core", "relief"},
          "rockpile": {"core"}, "fractal": {"core"}, "arches": {"core", "rockpile"},
          "asset": {"core", "blocks", "rockpile"}}  # asset: blocks/Hull.h (rockvdb_hull) and
# the rock pile's public headers (a pile's points and tile set as instances)


def test_stage_libraries_include_only_the_layers_below():
    import re
    ops = os.path.join(ROOT, "ops")
    seen = set()
    for layer, below in LAYERS.items():
        folder = os.path.join(ops, layer)
        for name in os.listdir(folder):
            if not name.endswith((".cc", ".h")):
                continue
            text = open(os.path.join(folder, name)).read()
            for used in re.findall(r'#include <rockvdb/(\w+)/\w+\.h>', text):
                if used in LAYERS and used != layer:
                    assert used in below, f"ops/{layer}/{name} includes {used}/"
                    seen.add((layer, used))
    # The layering is real: the upper layers do use the lower ones.
    assert {("blocks", "relief"), ("amplify", "blocks"), ("detail", "relief")} <= seen
    cmake = open(os.path.join(ops, "CMakeLists.txt")).read()
    for layer in LAYERS:
        assert f"rockvdb_layer(rockvdb_{layer}" in cmake, layer


def test_headers_are_included_with_the_rockvdb_prefix():
    """Outside its own folder a header is reached only as <rockvdb/LAYER/Name.h>; a bare
    <core/...> would need the ops/ folder on the include path, which no target exports."""
    import re
    bare = re.compile(r'#include [<"](?:%s)/' % "|".join(LAYERS))
    checked = 0
    for top in ("ops", "vdbtools", "python", "tests", "bench"):
        for dirpath, _, names in os.walk(os.path.join(ROOT, top)):
            for name in names:
                if not name.endswith((".cc", ".h")):
                    continue
                text = open(os.path.join(dirpath, name)).read()
                checked += 1
                assert not bare.search(text), os.path.join(dirpath, name)
    assert checked > 60


def _cmake_list(text, name):
    import re
    m = re.search(r"set\(%s\n(.*?)\)" % name, text, re.S)
    assert m, name
    return set(m[1].split())


def test_the_tsan_build_holds_every_test_the_tsan_job_runs():
    """.ci/sanitize's TSan job picks tests by suite name from a build that compiles only
    ROCKVDB_TSAN_TEST_SOURCES: a test of a picked suite in another file would silently not run
    under TSan, and a name the ASan job leaves out must name a test that exists."""
    import re
    cmake = open(os.path.join(ROOT, "tests", "CMakeLists.txt")).read()
    every = _cmake_list(cmake, "ROCKVDB_TEST_SOURCES")
    tsan = _cmake_list(cmake, "ROCKVDB_TSAN_TEST_SOURCES")
    assert tsan < every and len(tsan) >= 10
    script = open(os.path.join(ROOT, ".ci", "sanitize")).read()
    picked = re.compile(re.search(r"TSAN_RUN='([^']+)'", script)[1])
    skipped = re.compile(re.search(r"ASAN_SKIP='([^']+)'", script)[1])
    tests = {}
    for src in every:
        text = open(os.path.join(ROOT, "tests", src)).read()
        for suite, name in re.findall(r"^TEST(?:_F)?\((\w+),\s*(\w+)\)", text, re.M):
            tests[f"{suite}.{name}"] = src
    assert len(tests) > 200
    run = {t: src for t, src in tests.items() if picked.search(t)}
    assert len(run) > 60, len(run)
    assert {src for src in run.values()} <= tsan, {t: s for t, s in run.items() if s not in tsan}
    # The ASan job leaves out seven tests by name: each still names a test.
    left_out = [t for t in tests if skipped.fullmatch(t)]
    assert len(left_out) == 7, left_out
