"""rockvdb: procedural rocks and rocky terrain as OpenVDB level sets.

Fields compose like fogleman/sdf and bake to pyopenvdb grids:

    import rockvdb
    f = rockvdb.sphere(1.0) | rockvdb.box((2, 0.5, 0.5), rounding=0.1)
    grid = f.warp(0.05, frequency=2, seed=3).bake(voxel_size=0.02)
    rockvdb.write("rock.vdb", [grid])

Units are metres, values are signed distances (negative inside), z is up.
"""
import pyopenvdb  # noqa: F401  (registers the grid converters used by the extension)

from ._rockvdb import (Field, __version__, box, capsule, csg, expression, heightfield, mesh,
                       plane, polytope, preview, provenance, read, sphere, write,
                       write_heightfield)

__all__ = ["Field", "box", "capsule", "csg", "expression", "heightfield", "mesh", "plane",
           "polytope", "preview", "provenance", "read", "sphere", "write", "write_heightfield",
           "__version__"]
