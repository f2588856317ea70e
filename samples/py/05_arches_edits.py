# SPDX-License-Identifier: Apache-2.0
"""A material-stack terrain (arches §3) edited in Python (§4): a carved stroke, a sand deposit,
a collapse, a crack and a tunnel, each stabilised locally; baked with its material grids.

usage: PYTHONPATH=build/python /usr/bin/python3 samples/py/05_arches_edits.py [OUT_DIR]
"""
import os
import sys

import rockvdb

out = sys.argv[1] if len(sys.argv) > 1 else "out"
os.makedirs(out, exist_ok=True)
terrain = {"type": "strata", "samples": [40, 24],
           "layers": [{"material": "bedrock", "thickness": 10}, {"material": "sand", "thickness": 1}]}
s = rockvdb.Stacks(terrain, cell_size=0.5)
s.sculpt([(6, 5, 12), (7, 5.5, 12)], 1.5, mode="carve")
s.deposit((4, 9), 2.5, 1.0)
s.erode((14, 7, 10), 2.0, mode="collapse", rho=0.6)
s.crack([(3, 3), (10, 6), (16, 4)], profile=[(-1, 1), (1, 1), (0, -3)])
s.tunnel([(2, 9, 6), (18, 9, 6.5)], profile=[(-1, -1), (1, -1), (1, 1), (-1, 1)])
grids = s.bake(path=os.path.join(out, "py_arches.vdb"))
print(", ".join(f"{e['tool']} {e['stacks']} stacks" for e in s.edit_stats))
print(sorted(grids))
