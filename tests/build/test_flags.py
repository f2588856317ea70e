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
        command = e.get("command") or " ".join(e.get("arguments", []))
        files = [e["file"]]
        if "/Unity/unity_" in e["file"]:  # a unity batch (ROCKVDB_UNITY): its sources
            import re
            files = re.findall(r'^#include "([^"]+)"', open(e["file"]).read(), re.M)
        for f in files:
            by_file[os.path.relpath(os.path.realpath(f), os.path.realpath(ROOT))] = command
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


def test_the_demo_configures_the_tools_without_the_test_packages(tmp_path):
    """`./rockvdb.sh demo` installs only what the tools need: without GoogleTest (one of the
    packages only `test` installs) the tree configures the tools' target and leaves out the
    tests and the Python module, and every package the test-only lists name is one that the
    demo's list does not."""
    import re
    import subprocess
    p = subprocess.run(["cmake", "-S", ROOT, "-B", str(tmp_path), "-DCMAKE_BUILD_TYPE=Release",
                        "-DCMAKE_DISABLE_FIND_PACKAGE_GTest=ON", "-DROCKVDB_PCH=OFF"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "the Python module and the tests are not configured" in p.stdout
    p = subprocess.run(["cmake", "--build", str(tmp_path), "--target", "help"],
                       capture_output=True, text=True)
    targets = set(re.findall(r"^\.\.\. (\S+)", p.stdout, re.M))
    assert "rockvdb_tools" in targets and "vdb_amplify" in targets
    assert "rockvdb_tests" not in targets and "_rockvdb" not in targets
    script = open(os.path.join(ROOT, "rockvdb.sh")).read()
    lists = {name: set(body.split()) for name, body in
             re.findall(r"^(\w+_PACKAGES)=\(\n?(.*?)\)", script, re.M | re.S)}
    lists = {k: {w for w in v if not w.startswith("#")} for k, v in lists.items()}
    assert set(lists) == {"DEMO_PACKAGES", "BUILD_PACKAGES", "TEST_PACKAGES"}
    assert "libgtest-dev" in lists["BUILD_PACKAGES"] and "blender" in lists["TEST_PACKAGES"]
    assert not lists["DEMO_PACKAGES"] & (lists["BUILD_PACKAGES"] | lists["TEST_PACKAGES"])


# Unity builds (ROCKVDB_UNITY) compile a target's sources in batches, one translation unit a
# batch. Two sources defining the same file-local name (anonymous namespace or static) then
# clash: the same signature is a compile error, but different ones become overloads of each
# other, and a call could silently pick the other file's helper. So file-local names differ
# between the sources of a target (each group below is one target's sources or more).
UNITY_GROUPS = {f"ops/{layer}": f"ops/{layer}/*.cc" for layer in LAYERS}
UNITY_GROUPS.update({"tests": "tests/ops/*/*.cc", "python": "python/src/*.cc",
                     "vdbtools": "vdbtools/[A-Z]*.cc", "bench": "bench/*.cc"})


def _file_local_names(path):
    """Names a source gives internal linkage at namespace scope: declared directly in an
    anonymous namespace, or static outside any class or function."""
    import re
    text = open(path).read()
    text = re.sub(r"//[^\n]*|/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r'"(\\.|[^"\\\n])*"' + r"|'(\\.|[^'\\\n])*'", '""', text)
    text = re.sub(r"^\s*#[^\n]*", "", text, flags=re.M)
    stack, heads, start = [], [], 0
    for m in re.finditer(r"[{};]", text):
        part, start = text[start:m.start()].strip(), m.end()
        namespace_scope = all(k in ("ns", "anon") for k in stack)
        local = stack[-1:] == ["anon"] or (namespace_scope and re.match(r"static\b", part))
        if m[0] == "{":
            if re.search(r"\bnamespace$", part):
                stack.append("anon")
                continue
            if re.search(r"\bnamespace\s+[\w:]+$", part):
                stack.append("ns")
                continue
            stack.append("block")
        elif m[0] == "}":
            stack and stack.pop()
            continue
        if local and part:
            heads.append(re.sub(r"\s+", " ", part))
    names = set()
    for h in heads:
        h = re.sub(r"^template ?<.*?> ?", "", h)
        if re.match(r"(using|typedef|return|friend)\b", h) and not re.match(r"using \w+ ?=", h):
            continue
        m = (re.match(r"(?:enum(?: class)?|class|struct|union) (\w+)", h)
             or re.match(r"using (\w+) ?=", h)
             or re.search(r"(\w+) ?\(", h.split("=")[0])
             or re.search(r"(\w+)(?: ?\[[^\]]*\])* ?(?:=|$)", h))
        if m:
            names.add(m[1])
    return names


def test_file_local_names_differ_between_the_sources_of_a_target():
    import glob
    clashes = []
    for group, pattern in UNITY_GROUPS.items():
        where = {}
        files = sorted(glob.glob(os.path.join(ROOT, pattern)))
        assert files, pattern
        for f in files:
            for name in _file_local_names(f):
                where.setdefault(name, []).append(os.path.relpath(f, ROOT))
        clashes += [f"{group}: {n} in {', '.join(fs)}" for n, fs in where.items() if len(fs) > 1]
    assert not clashes, clashes
    # The scan finds what it looks for: a source's helpers and types by name.
    names = _file_local_names(os.path.join(ROOT, "tests/ops/core/TestVdbIO.cc"))
    assert {"tmp", "smallSphere", "filesIn"} <= names, names
    names = _file_local_names(os.path.join(ROOT, "ops/detail/Detail.cc"))
    assert {"GaborDetail", "lerp", "kMaxWidenVoxels"} <= names, names
