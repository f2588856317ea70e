# SPDX-License-Identifier: Apache-2.0
"""Every command in the README and its pages (docs/*.md) runs as written: each ```sh and
```python block (except those marked `norun`, the two set-up commands and the install lines)
runs in reading order (the README, then PAGES) from a scratch folder laid out like the
repository root (build/ and samples/ linked in), sharing the files it writes in out/."""
import os
import re
import subprocess

import pytest

from conftest import BUILD

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
FENCE = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```", re.M | re.S)


# The pages in the order the README's table leads to them (later pages read files earlier
# ones wrote in out/).
PAGES = ["README.md"] + [f"docs/{p}.md" for p in (
    "tools", "blocks", "amplify", "detail", "rockpile", "fractal", "arches", "asset", "blender",
    "distributed", "conventions", "benchmarks", "gallery")]


def blocks():
    out = []
    for page in PAGES:
        text = open(os.path.join(ROOT, page)).read()
        for m in FENCE.finditer(text):
            lang, info, body = m[1], m[2], m[3]
            if lang in ("sh", "python") and "norun" not in info:
                line = text[:m.start()].count("\n") + 1
                out.append(pytest.param(lang, body, id=f"{page}:{line}-{lang}"))
    return out


def test_every_page_is_read_and_the_readme_stays_short():
    pages = {f"docs/{f}" for f in os.listdir(os.path.join(ROOT, "docs")) if f.endswith(".md")}
    assert pages == set(PAGES[1:])
    readme = open(os.path.join(ROOT, "README.md")).read()
    assert readme.count("\n") <= 250
    for page in PAGES[1:]:
        assert f"({page})" in readme, f"the README links no {page}"
    # Every relative link of every page leads to a file.
    for page in PAGES:
        text = open(os.path.join(ROOT, page)).read()
        for target in re.findall(r"\]\(([^)#:]+)\)", text):
            path = os.path.normpath(os.path.join(ROOT, os.path.dirname(page), target))
            assert os.path.exists(path), f"{page}: broken link {target}"


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    d = tmp_path_factory.mktemp("readme")
    os.symlink(os.path.abspath(BUILD), d / "build")
    os.symlink(os.path.join(ROOT, "samples"), d / "samples")
    return d


def test_the_readme_has_runnable_blocks_for_every_tool():
    text = "".join(b.values[1] for b in blocks())
    for t in ("vdb_primitive", "vdb_heightfield", "vdb_csg", "vdb_mesh", "vdb_preview",
              "vdb_info", "vdb_blocks", "vdb_amplify", "vdb_merge", "vdb_detail",
              "vdb_rockpile", "vdb_fractal_rock", "vdb_arches", "rockvdb.fractal_rock", "rockvdb.amplify", "rockvdb.detail", "rockvdb.rock_pile",
              "rockvdb.block_tile", "samples/02_blocks.sh", "samples/03_amplify.sh",
              "samples/04_detail.sh", "samples/05_rockpile.sh", "samples/06_riverbed.sh", "samples/07_fractal_boulders.sh", "samples/08_arches.sh", "samples/09_arches_coast.sh", "samples/10_arches_ravine.sh", "samples/11_arches_canyon_collapse.sh", "samples/12_detail_skeleton.sh", "rockvdb.Stacks",
              "rockvdb.fractal_scatter", "rockvdb.fractal_carve", "vdb_asset", "rockvdb.asset",
              "rockvdb.asset_each"):
        assert t in text, t


@pytest.mark.parametrize("lang,body", blocks())
def test_block_runs_as_written(root, lang, body):
    env = dict(os.environ, PYTHONPATH=str(root / "build" / "python"))
    if lang == "sh":
        cmd = ["bash", "-euo", "pipefail", "-c", body]
    else:
        cmd = ["/usr/bin/python3", "-c", body]
    p = subprocess.run(cmd, cwd=str(root), env=env, capture_output=True, text=True,
                       timeout=900)
    assert p.returncode == 0, f"{body}\n--- stderr:\n{p.stderr[-3000:]}"
