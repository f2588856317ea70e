"""rockvdb: procedural rocks and rocky terrain as OpenVDB level sets.

Fields compose like fogleman/sdf and bake to pyopenvdb grids:

    import rockvdb
    f = rockvdb.sphere(1.0) | rockvdb.box((2, 0.5, 0.5), rounding=0.1)
    grid = f.warp(0.05, frequency=2, seed=3).bake(voxel_size=0.02)
    rockvdb.write("rock.vdb", [grid])

Units are metres, values are signed distances (negative inside), z is up.
"""
import pyopenvdb  # noqa: F401  (registers the grid converters used by the extension)

import json as _json

from . import _rockvdb
from ._rockvdb import (Field, __version__, box, capsule, csg, expression, heightfield, mesh,
                       plane, polytope, preview, provenance, read, sphere, write,
                       write_heightfield)

__all__ = ["BlockTile", "Field", "amplify", "block_tile", "box", "capsule", "csg", "detail",
           "expression",
           "heightfield", "load_tile", "mesh", "plane", "polytope", "preview", "provenance",
           "read", "sphere", "write", "write_heightfield", "__version__"]


class BlockTile:
    """A fractured block tile: ``params``, ``blocks`` and ``stats`` (dicts as in the tile
    file), and after a bake ``surface`` / ``block_id`` (pyopenvdb.FloatGrid)."""

    def __init__(self, tile):
        self._tile = tile
        data = _json.loads(tile.to_json())
        self.params = data["params"]
        self.blocks = data["blocks"]
        self.discs = data["discs"]
        self.stats = data.get("stats", {})
        self.surface = None
        self.block_id = None

    def bake(self, voxel_size=0.05, half_width=3.0, periods=(1, 1, 1)):
        """Bake the tile; sets and returns (surface, block_id)."""
        self.surface, self.block_id = self._tile.bake(voxel_size, half_width, list(periods))
        return self.surface, self.block_id

    def field(self, periods=(1, 1, 1), periodic=False):
        """The tile as a rockvdb.Field (periodic=True: the infinite tiling)."""
        return self._tile.field(list(periods), periodic)

    def save(self, path):
        """Write the tile file (JSON 'rockvdb-tile')."""
        self._tile.save(str(path))

    def __repr__(self):
        return (f"<BlockTile {self.params['type']} {self.params['tile_size']} m: "
                f"{len(self.blocks)} blocks>")


_TILE_KEYS = ("tile_size", "point_radius", "neighbour_radius", "disc_count", "disc_spacing",
              "disc_radius", "jitter", "irregular_fraction", "axis", "oblique_angle",
              "min_points", "smooth_radius", "fractures", "authored")
_RELIEF_KEYS = {"warp_amplitude": "amplitude", "relief_scale": "scale",
                "relief_octaves": "octaves", "relief_image": "image",
                "relief_sharpness": "sharpness"}


def block_tile(type="equidimensional", seed=1, voxel_size=0.05, periods=(1, 1, 1),
               half_width=3.0, bake=True, **params):
    """Generate a block tile (vdb_blocks' parameters as keyword arguments: tile_size,
    point_radius, disc_count, disc_radius=(min, max), axis, fractures=[{center, normal,
    radius}], authored=[{type: box|polytope, ...}], warp_amplitude, relief_image, ...).
    With bake=True (default) the grids are baked at voxel_size over ``periods``."""
    spec = {"type": type, "seed": int(seed)}
    relief = {}
    for key, value in params.items():
        if key in _TILE_KEYS:
            spec[key] = list(value) if isinstance(value, tuple) else value
        elif key in _RELIEF_KEYS:
            relief[_RELIEF_KEYS[key]] = value
        else:
            raise TypeError(f"block_tile() got an unexpected keyword argument '{key}'")
    if relief:
        spec["relief"] = relief
    tile = BlockTile(_rockvdb.generate_tile(_json.dumps(spec)))
    if bake:
        tile.bake(voxel_size, half_width, periods)
    return tile


def load_tile(path):
    """Read a tile file (.tile) or a vdb_blocks .vdb; returns an unbaked BlockTile."""
    return BlockTile(_rockvdb.load_tile(str(path)))



def amplify(terrain, tiles, strata=None, max_slope=0.5, distance_range=(-1.0, 0.5), anchors=8,
            fraction=0.5, voxel_size=0.1, half_width=3.0, region=None, roi=None, mask=None,
            mask_cell_size=0.0, carve=0.0, mixed_tile_sizes=False, cell_size=1.0,
            height_scale=1.0, base_depth=1.0, stats=None):
    """Amplify a terrain with block tiles (implicit-blocks §5); vdb_amplify from Python.

    terrain: a pyopenvdb.FloatGrid level set, or a heightfield image path (cell_size,
    height_scale, base_depth apply). tiles: BlockTile objects or tile paths (.tile / .vdb);
    strata: a dict or JSON file (see vdb_amplify --strata) naming tiles by file stem or
    index, required for several tiles. region: the bake box (xmin, ymin, zmin, xmax, ymax, zmax) for chunked
    baking; roi: the box anchors must lie in; mask: an image path or a 2D array (row j at
    y = j * mask_cell_size, 0 = cell_size) where blocks are allowed (>= 0.5); carve > 0: the
    carving variant with that gap (m). stats: a dict to fill with #R ("replicated"), block
    field bytes, active voxels and the time per phase.
    Returns (surface, block_id, material) pyopenvdb grids."""
    import os
    if terrain is None:
        raise TypeError("amplify(): terrain must be a pyopenvdb.FloatGrid or a heightfield path")
    loaded, names = [], []
    for i, t in enumerate(tiles):
        if isinstance(t, BlockTile):
            loaded.append(t._tile)
            names.append(str(i))
        else:
            loaded.append(_rockvdb.load_tile(str(t)))
            names.append(os.path.splitext(os.path.basename(str(t)))[0])
    if isinstance(strata, (str, os.PathLike)):
        with open(strata) as f:
            strata = _json.load(f)
    mask_array = None
    if isinstance(mask, (str, os.PathLike)):
        mask_array = _rockvdb.read_image(str(mask), "mask")
    elif mask is not None:
        mask_array = mask
    options = {"strata": strata, "max_slope": float(max_slope),
               "distance_range": [float(v) for v in distance_range], "anchors": int(anchors),
               "fraction": float(fraction), "voxel_size": float(voxel_size),
               "half_width": float(half_width),
               "region": [float(v) for v in region] if region is not None else None,
               "roi": [float(v) for v in roi] if roi is not None else None,
               "mask_cell_size": float(mask_cell_size), "carve": float(carve),
               "mixed_tile_sizes": bool(mixed_tile_sizes), "cell_size": float(cell_size),
               "height_scale": float(height_scale), "base_depth": float(base_depth)}
    if isinstance(terrain, os.PathLike):
        terrain = str(terrain)
    surface, block_id, material, st = _rockvdb.amplify(terrain, loaded, names, mask_array,
                                                       _json.dumps(options))
    if stats is not None:
        stats.update(st)
    return surface, block_id, material


def detail(grid, warp_amplitude=0.0, warp_relief="turbulence", warp_scale=1.5, warp_octaves=4,
           warp_sharpness=8.0, gabor_amplitude=0.0, gabor_frequency=0.0, gabor_bandwidth=0.0,
           gabor_orientation=0.0, gabor_impulses=16.0, gabor_falloff=0.0,
           gabor_isotropic=False, tilt=(0.0, 0.0), direction_axis=None,
           direction_skeleton=None, direction_curvature=False, singular="auto", seed=0,
           voxel_size=None, half_width=None, blend=None, blend_mask=None):
    """Surface detail on a level set (vdb_detail from Python): gradient warp (implicit-blocks
    §4.2) and Gabor details (gabor-details §3-§4). grid: a pyopenvdb.FloatGrid level set;
    amplitudes in metres (0 disables), frequency in cycles per metre, angles in degrees;
    direction_skeleton: a dict {"segments": [...]} or a JSON file path. voxel_size and
    half_width default to the input's. blend: a dict of the parameters that may vary in space
    (warp_amplitude, gabor_amplitude, gabor_frequency, gabor_orientation, gabor_falloff, tilt)
    reached where blend_mask (a pyopenvdb.FloatGrid of weights in [0, 1]) reads 1; the
    parameters are interpolated (gabor §4), so blends do not blur the details.
    Returns a new pyopenvdb.FloatGrid (input untouched)."""
    import os
    if isinstance(direction_skeleton, os.PathLike):
        direction_skeleton = str(direction_skeleton)
    options = {"warp_amplitude": float(warp_amplitude), "warp_relief": str(warp_relief),
               "warp_scale": float(warp_scale), "warp_octaves": int(warp_octaves),
               "warp_sharpness": float(warp_sharpness), "gabor_amplitude": float(gabor_amplitude),
               "gabor_frequency": float(gabor_frequency), "gabor_bandwidth": float(gabor_bandwidth),
               "gabor_orientation": float(gabor_orientation),
               "gabor_impulses": float(gabor_impulses), "gabor_falloff": float(gabor_falloff),
               "gabor_isotropic": bool(gabor_isotropic), "tilt": [float(t) for t in tilt],
               "direction_axis": ([float(a) for a in direction_axis]
                                  if direction_axis is not None else None),
               "direction_skeleton": direction_skeleton,
               "direction_curvature": bool(direction_curvature), "singular": str(singular),
               "seed": int(seed)}
    if blend is not None:
        options["blend"] = blend
    if blend is not None and blend_mask is None:
        raise ValueError("detail: blend needs blend_mask (the weights)")
    return _rockvdb.detail(grid, _json.dumps(options), voxel_size, half_width, blend_mask)


def rock_tiles(n=5, seeds_per_cell=(1, 1), anisotropy=(1.0, 1.0, 1.0), anisotropy_jitter=0.25,
               g_max=2.0, voxels_per_cell=10, cube_size=1.0, contact_radii=(0.08, 0.3),
               erosion_steps=6, erosion_rate=0.5, tiling="aperiodic", poisson_radius=0.0,
               seed=0, path=None):
    """A rock tile set (vdb_rockpile tiles from Python; aperiodic-rock-piles §2-§5, arches §5).
    Returns the tile set as a pyopenvdb.FloatGrid 'rho' (each rock's erosion state in its own
    slot, the description in metadata 'rockvdb:tiles'); path also writes it. Lengths in cells
    (cube_size / n metres). anisotropy: the relative extents (alpha, beta, gamma) of the rocks
    along each seed's random frame; (5, 5, 1) makes flat rocks."""
    options = {"tiling": str(tiling), "n": int(n),
               "seeds_per_cell": [int(s) for s in seeds_per_cell],
               "anisotropy": [float(a) for a in anisotropy],
               "anisotropy_jitter": float(anisotropy_jitter), "g_max": float(g_max),
               "voxels_per_cell": int(voxels_per_cell), "cube_size": float(cube_size),
               "contact_radii": [float(r) for r in contact_radii],
               "erosion_steps": int(erosion_steps), "erosion_rate": float(erosion_rate),
               "poisson_radius": float(poisson_radius), "seed": int(seed)}
    grid = _rockvdb.rock_tiles(_json.dumps(options))
    if path is not None:
        pyopenvdb.write(str(path), [grid])
    return grid


def _tile_grid(tiles):
    import os
    if isinstance(tiles, (str, os.PathLike)):
        return pyopenvdb.read(str(tiles), "rho")
    return tiles


def rock_library(tiles):
    """Every rock of a tile set (a 'rho' grid or a tile file path) as a level set 'library',
    each rock in its own slot (offsets in metadata 'rockvdb:library_offsets')."""
    return _rockvdb.rock_library(_tile_grid(tiles))


def rock_pile(tiles, support, threshold=0.5, keep_deep=False, seed=0, stats=None):
    """Fill a support with a tile set's rocks (vdb_rockpile pile from Python; §6). tiles: a
    'rho' grid or a tile file path; support: a pyopenvdb.FloatGrid level set, a rockvdb Field
    (e.g. rockvdb.sphere(...)), or a path (.vdb, .json expression, closed .obj/.stl/.ply).
    Returns (surface, rock_id) grids; stats (a dict) receives counts, times, and each placed
    rock's library index and seed position."""
    import os
    if isinstance(support, os.PathLike):
        support = str(support)
    options = {"threshold": float(threshold), "keep_deep": bool(keep_deep), "seed": int(seed)}
    surface, rock_id, info = _rockvdb.rock_pile(_tile_grid(tiles), support, _json.dumps(options))
    if stats is not None:
        stats.update(info)
    return surface, rock_id
