# SPDX-License-Identifier: Apache-2.0
"""rockvdb is Apache-2.0 (OpenVDB's license, the field's norm): the license text at the top
level, an SPDX identifier at the head of every source, build and script file we track, and
both installed beside the README, the docs and the samples (issue 41)."""
import os
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SPDX = "SPDX-License-Identifier: Apache-2.0"
SOURCES = (".cc", ".h", ".py", ".sh", ".cmake")
SCRIPTS = {"CMakeLists.txt", "run", "sanitize", "rockvdb.sh"}


def tracked():
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True)
    return out.stdout.split()


def test_the_license_is_apache_2_0():
    text = open(os.path.join(ROOT, "LICENSE")).read()
    assert text.lstrip().startswith("Apache License")
    assert "Version 2.0, January 2004" in text and "http://www.apache.org/licenses/" in text
    # The whole text, not a summary: its nine sections and the appendix.
    assert "9. Accepting Warranty or Additional Liability." in text and "APPENDIX" in text
    assert "rockvdb" in open(os.path.join(ROOT, "NOTICE")).read()


def test_every_source_file_names_its_license():
    files = [f for f in tracked()
             if f.endswith(SOURCES) or os.path.basename(f) in SCRIPTS]
    assert len(files) > 200, len(files)
    missing = []
    for f in files:
        with open(os.path.join(ROOT, f), errors="replace") as fh:
            head = [fh.readline() for _ in range(3)]
        if not any(SPDX in line for line in head):
            missing.append(f)
    assert not missing, f"{len(missing)} files without '{SPDX}' in their first 3 lines: {missing[:10]}"
