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
