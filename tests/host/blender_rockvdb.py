# SPDX-License-Identifier: Apache-2.0
"""Run by headless Blender: rockvdb's Python inside a host that loaded OpenVDB itself. Every
grid call of host_calls.py, then the written .vdb imported as a volume object and its
'surface' meshed, all in this one Blender process.
usage: blender -b --factory-startup --python blender_rockvdb.py -- PYTHONPATH_DIR OUT_DIR"""
import json
import os
import sys

argv = sys.argv[sys.argv.index("--") + 1:]
here = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [argv[0], here, os.path.join(here, "..", "clients")]
out = argv[1]

import host_calls  # noqa: E402  (needs the paths above)
from blender_mesh import mesh_surface  # noqa: E402

report = host_calls.run(out)
m = mesh_surface(os.path.join(out, "host.vdb"))
report["blender_grids"] = sorted(m["grids"])
report["blender_vertices"] = m["vertices"]
report["blender_min"] = m["min"] if m["vertices"] else None
report["blender_max"] = m["max"] if m["vertices"] else None
with open(os.path.join(out, "host.json"), "w") as f:
    json.dump(report, f)
