# SPDX-License-Identifier: Apache-2.0
"""vdb_detail / rockvdb.detail (issue 5): gradient warp and Gabor details on level sets.

Properties: zero amplitude is the identity, the surface moves by at most the amplitude (+1
voxel), topology is unchanged (components and Euler characteristic of the mesh), Gabor
anisotropy follows the requested orientation (power spectrum of a flat patch), tilt makes the
profile asymmetric, bitwise determinism across thread counts, bad input."""
import json
import math

import numpy as np
import pyopenvdb as vdb
import pytest

import rockvdb
from conftest import around, dense, one_line_error, run, run_sample, tool


@pytest.fixture(scope="module")
def sphere(tmp_path_factory):
    d = tmp_path_factory.mktemp("detail")
    path = d / "sphere.vdb"
    run([tool("vdb_primitive"), "-q", "sphere", "--radius", "1", "--voxel-size", "0.02",
         "-o", str(path)], check=True)
    return path


@pytest.fixture(scope="module")
def patch(tmp_path_factory):
    """A 4 m x 4 m x 1 m slab at 2 cm voxels: its top face is the flat patch."""
    d = tmp_path_factory.mktemp("patch")
    path = d / "slab.vdb"
    run([tool("vdb_primitive"), "-q", "box", "--size", "4,4,1", "--voxel-size", "0.02",
         "-o", str(path)], check=True)
    return path


def detail(inp, out, *args):
    """vdb_detail with @a args; no warp unless they ask for one (the tests isolate each
    operator; the tool's default warp is 2 cm)."""
    if "--warp-amplitude" not in args:
        args = ("--warp-amplitude", "0") + args
    p = run([tool("vdb_detail"), "-q", str(inp), "-o", str(out), *args])
    assert p.returncode == 0, p.stderr
    return vdb.read(str(out), "surface")


def mesh_topology(grid):
    """(connected components, Euler characteristic) of the grid's zero isosurface mesh."""
    pts, tris, quads = grid.convertToPolygons(0.0, 0.0)
    faces = [f for f in (tris, quads) if len(f)]
    edges = set()
    parent = list(range(len(pts)))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    nfaces = 0
    for fs in faces:
        nfaces += len(fs)
        for f in fs.tolist():
            for k in range(len(f)):
                a, b = f[k], f[(k + 1) % len(f)]
                edges.add((min(a, b), max(a, b)))
                ra, rb = find(a), find(b)
                if ra != rb:
                    parent[ra] = rb
    used = {find(i) for fs in faces for f in fs.tolist() for i in f}
    return len(used), len(pts) - len(edges) + nfaces, pts


def radial_error(grid):
    pts, _, _ = grid.convertToPolygons(0.0, 0.0)
    return np.abs(np.linalg.norm(pts, axis=1) - 1.0)


def test_zero_amplitude_returns_the_input(sphere, tmp_path):
    g = detail(sphere, tmp_path / "o.vdb", "--warp-amplitude", "0", "--gabor-amplitude", "0")
    ref = vdb.read(str(sphere), "surface")
    assert g.activeVoxelCount() == ref.activeVoxelCount()
    (lo, a), (lo2, b) = dense(ref), dense(g)
    assert lo == lo2
    assert np.max(np.abs(a - b)) < 1e-4 * 0.02


@pytest.mark.parametrize("args,amp", [
    (["--warp-amplitude", "0.05", "--warp-scale", "0.8"], 0.05),
    (["--gabor-amplitude", "0.04", "--gabor-frequency", "5", "--direction-axis", "0,0,1"], 0.04),
    (["--warp-amplitude", "0.03", "--gabor-amplitude", "0.03", "--gabor-frequency", "6",
      "--direction-curvature"], 0.06),
])
def test_displacement_bound_and_topology_on_a_sphere(sphere, tmp_path, args, amp):
    g = detail(sphere, tmp_path / "o.vdb", *args)
    err = radial_error(g)
    assert err.max() <= amp + 0.02, err.max()
    # The detail is real: the surface moves by a good part of the amplitude somewhere.
    assert err.max() > 0.4 * amp
    # One component, Euler characteristic 2 (a sphere): no holes, no floating bits.
    comps, chi, _ = mesh_topology(g)
    assert (comps, chi) == (1, 2)
    # A valid narrow-band level set.
    assert g.gridClass == vdb.GridClass.LEVEL_SET
    assert abs(g.background - 3 * 0.02) < 1e-6
    _, a = dense(g)
    assert np.all(np.abs(a) <= g.background + 1e-6)


def test_topology_of_a_block_tile_is_unchanged(tmp_path):
    tile = tmp_path / "tile.vdb"
    run([tool("vdb_blocks"), "-q", "--type", "equidimensional", "--tile-size", "4",
         "--point-radius", "0.25", "--voxel-size", "0.03", "--warp-amplitude", "0",
         # fractures 5 voxels wide, so that the detail's 2 cm cannot bridge them; edges
         # rounded by 25 cm (8 voxels), so that it cannot pinch a corner off either (the
         # 4 m tile's own default R is 5 cm)
         "--fracture-width", "0.15", "--smooth-radius", "0.25", "--seed", "5", "-o", str(tile)],
        check=True)
    before = mesh_topology(vdb.read(str(tile), "surface"))[:2]
    assert before[0] > 3
    for args in (["--warp-amplitude", "0.02", "--warp-scale", "0.5"],
                 ["--gabor-amplitude", "0.02", "--gabor-frequency", "6",
                  "--direction-curvature"]):
        after = mesh_topology(detail(tile, tmp_path / "o.vdb", *args))[:2]
        assert after == before, (args, before, after)


def heightmap(grid, z0=0.5, margin=0.6):
    """Top surface height over the slab's face (linear zero crossing per column)."""
    dx = grid.transform.voxelSize()[0]
    n = int(round((4.0 - 2 * margin) / dx))
    i0 = int(round((-2.0 + margin) / dx))
    k0, k1 = int(round((z0 - 0.3) / dx)), int(round((z0 + 0.3) / dx))
    a = np.zeros((n, n, k1 - k0 + 1), np.float32)
    grid.copyToArray(a, ijk=(i0, i0, k0))
    h = np.full((n, n), np.nan)
    for k in range(a.shape[2] - 1, 0, -1):
        lo, hi = a[:, :, k - 1], a[:, :, k]
        hit = np.isnan(h) & (lo <= 0) & (hi > 0)
        h[hit] = (k0 + k - 1 + lo[hit] / (lo[hit] - hi[hit])) * dx
    assert not np.isnan(h).any()
    return h - z0


def dominant_angle(h, dx, f0):
    """Power-weighted orientation (degrees mod 180) of the spectrum near |k| = f0."""
    spec = np.abs(np.fft.fftshift(np.fft.fft2(h - h.mean()))) ** 2
    kx, ky = np.meshgrid(np.fft.fftshift(np.fft.fftfreq(h.shape[0], dx)),
                         np.fft.fftshift(np.fft.fftfreq(h.shape[1], dx)), indexing="ij")
    r = np.hypot(kx, ky)
    sel = (r > 0.5 * f0) & (r < 1.5 * f0)
    ang = np.arctan2(ky[sel], kx[sel])
    w = spec[sel]
    c, s = (w * np.cos(2 * ang)).sum(), (w * np.sin(2 * ang)).sum()
    return (math.degrees(math.atan2(s, c)) / 2) % 180, math.hypot(c, s) / w.sum()


@pytest.mark.parametrize("orientation", [30.0, 100.0])
def test_anisotropy_follows_the_orientation(patch, tmp_path, orientation):
    # W = x on the top face: b = n ^ W = y, t = b ^ n = x; ω is measured from t (x) to b (y).
    g = detail(patch, tmp_path / "o.vdb", "--gabor-amplitude", "0.02", "--gabor-frequency", "4",
               "--gabor-bandwidth", "1", "--gabor-orientation", str(orientation),
               "--direction-axis", "1,0,0")
    h = heightmap(g)
    assert np.abs(h).max() <= 0.02 + 0.02
    angle, strength = dominant_angle(h, 0.02, 4.0)
    diff = abs((angle - orientation + 90) % 180 - 90)
    assert diff < 10, (angle, orientation)
    assert strength > 0.5  # clearly anisotropic
    # Isotropic noise has no preferred direction.
    # (A wider band, so the patch holds many independent kernels.)
    gi = detail(patch, tmp_path / "i.vdb", "--gabor-amplitude", "0.02", "--gabor-frequency", "4",
                "--gabor-bandwidth", "2", "--gabor-isotropic")
    assert dominant_angle(heightmap(gi), 0.02, 4.0)[1] < 0.25


def slope_skew(h, dx):
    s = np.diff(h, axis=0).ravel() / dx
    s = s - s.mean()
    return float((s ** 3).mean() / (s ** 2).mean() ** 1.5)


def test_tilt_makes_the_profile_asymmetric(patch, tmp_path):
    common = ["--gabor-amplitude", "0.03", "--gabor-frequency", "3", "--gabor-bandwidth", "1",
              "--gabor-orientation", "0", "--direction-axis", "1,0,0"]
    flat = slope_skew(heightmap(detail(patch, tmp_path / "a.vdb", *common)), 0.02)
    tilted = slope_skew(heightmap(detail(patch, tmp_path / "b.vdb", *common, "--tilt", "50,0")),
                        0.02)
    back = slope_skew(heightmap(detail(patch, tmp_path / "c.vdb", *common, "--tilt", "50,180")),
                      0.02)
    assert abs(flat) < 0.15, flat
    assert abs(tilted) > 3 * max(abs(flat), 0.05), (flat, tilted)
    # Tilting the other way mirrors the asymmetry.
    assert tilted * back < 0, (tilted, back)


def test_threads_give_identical_grids(sphere, tmp_path):
    args = ["--warp-amplitude", "0.03", "--gabor-amplitude", "0.03", "--gabor-frequency", "6",
            "--direction-axis", "0,1,1"]
    g1 = detail(sphere, tmp_path / "1.vdb", "--threads", "1", *args)
    g2 = detail(sphere, tmp_path / "2.vdb", "--threads", "2", *args)
    assert g1.activeVoxelCount() == g2.activeVoxelCount()
    (l1, a1), (l2, a2) = dense(g1), dense(g2)
    assert l1 == l2 and np.array_equal(a1, a2)
    # Another seed gives another surface.
    g3 = detail(sphere, tmp_path / "3.vdb", "--seed", "9", *args)
    l3, a3 = dense(g3)
    assert l3 != l1 or a3.shape != a1.shape or not np.array_equal(a3, a1)


def test_python_matches_the_cli_and_skeleton_frames(sphere, tmp_path):
    args = dict(gabor_amplitude=0.03, gabor_frequency=6.0, direction_axis=(0, 0, 1), seed=3,
                warp_amplitude=0.0)
    g = rockvdb.detail(vdb.read(str(sphere), "surface"), **args)
    c = detail(sphere, tmp_path / "c.vdb", "--gabor-amplitude", "0.03", "--gabor-frequency", "6",
               "--direction-axis", "0,0,1", "--seed", "3")
    assert np.array_equal(dense(g)[1], dense(c)[1])
    assert json.loads(g.metadata["rockvdb:params"])["gabor-frequency"] == 6.0
    # A skeleton along z gives the same frames as the z axis near it (W = f·S, same direction),
    # with the axis's treatment of the poles (skeleton frames fade to isotropic by default).
    skel = {"segments": [{"a": [0, 0, -2], "b": [0, 0, 2], "radius": 10}]}
    gs = rockvdb.detail(vdb.read(str(sphere), "surface"), gabor_amplitude=0.03, warp_amplitude=0.0,
                        gabor_frequency=6.0, direction_skeleton=skel, singular="cancel", seed=3)
    (la, a), (lb, b) = dense(gs), dense(g)
    assert la == lb and np.max(np.abs(a - b)) < 0.02 * 0.02
    with pytest.raises(ValueError, match="Nyquist"):
        rockvdb.detail(vdb.read(str(sphere), "surface"), gabor_amplitude=0.03,
                       gabor_frequency=40.0)


@pytest.mark.parametrize("args,needle", [
    (["--warp-amplitude", "-0.1"], "detail: warp-amplitude must be in [0, 1000] (got -0.1)"),
    (["--gabor-amplitude", "-1"], "detail: gabor-amplitude must be in [0, 1000] (got -1.0)"),
    (["--gabor-amplitude", "0.02", "--gabor-frequency", "30"], "Nyquist limit"),
    (["--gabor-amplitude", "0.02", "--gabor-frequency", "5", "--tilt", "80,0"], "tilt"),
    (["--gabor-amplitude", "0.02", "--gabor-frequency", "5", "--gabor-falloff", "0.01"],
     "falloff"),
    (["--warp-amplitude", "0.02", "--warp-relief", "missing.png"], "missing.png"),
    (["--warp-amplitude", "5"], "widened by"),
    (["--gabor-amplitude", "3", "--gabor-frequency", "1"], "widened by"),
])
def test_bad_parameters(sphere, tmp_path, args, needle):
    out = tmp_path / "o.vdb"
    p = run([tool("vdb_detail"), str(sphere), "-o", str(out), *args])
    assert p.returncode in (1, 2)
    one_line_error(p, p.returncode, needle)
    assert not out.exists()


def test_bad_inputs(tmp_path, sphere):
    fog = tmp_path / "fog.vdb"
    g = vdb.read(str(sphere), "surface")
    g.gridClass = vdb.GridClass.FOG_VOLUME
    vdb.write(str(fog), grids=[g])
    out = tmp_path / "o.vdb"
    one_line_error(run([tool("vdb_detail"), str(fog), "-o", str(out), "--warp-amplitude",
                        "0.02"]), 2, "fog volume")
    skel = tmp_path / "skel.json"
    skel.write_text('{"segments": [{"a": [0, 0, 0], "b": [0, 0, 0], "radius": 1}]}')
    one_line_error(run([tool("vdb_detail"), str(sphere), "-o", str(out), "--gabor-amplitude",
                        "0.02", "--gabor-frequency", "5", "--direction-skeleton", str(skel)]),
                   2, "segment length")
    assert not out.exists()
    # Unknown keys of a skeleton name themselves (issue 39: they were ignored).
    skel.write_text('{"segments": [{"a": [0, 0, -1], "b": [0, 0, 1], "radius": 2}], "point": []}')
    one_line_error(run([tool("vdb_detail"), str(sphere), "-o", str(out), "--gabor-amplitude",
                        "0.02", "--gabor-frequency", "5", "--direction-skeleton", str(skel)]),
                   2, '"point"')
    assert not out.exists()
    with pytest.raises(ValueError, match="level set"):
        rockvdb.detail(g, warp_amplitude=0.02)


def displacement(src, out, voxel, pad=4):
    """|out − src| over src's active box grown by pad voxels, the mask of src's near-surface
    voxels (|φ| < a voxel), and the box's lower corner."""
    lo, hi = src.evalActiveVoxelBoundingBox()
    lo, hi = [v - pad for v in lo], [v + pad for v in hi]
    a0 = around(src, lo, hi)
    return np.abs(around(out, lo, hi) - a0), np.abs(a0) < voxel, lo


def test_detail_only_along_a_skeleton_that_carries_it(sphere, tmp_path):
    """gabor-amplitude 0 and a point skeleton at the north pole carrying an amplitude: the
    sphere is detailed there and nowhere out of the point's reach, the same from the CLI and
    Python."""
    skel = {"points": [{"p": [0, 0, 1], "radius": 0.6, "amplitude": 0.02, "frequency": 6}]}
    (tmp_path / "s.json").write_text(json.dumps(skel))
    c = detail(sphere, tmp_path / "c.vdb", "--gabor-amplitude", "0", "--direction-skeleton",
               str(tmp_path / "s.json"), "--seed", "4")
    g = rockvdb.detail(vdb.read(str(sphere), "surface"), gabor_amplitude=0.0, direction_skeleton=skel,
                       seed=4, warp_amplitude=0.0)
    assert np.array_equal(dense(g)[1], dense(c)[1])
    diff, near, lo = displacement(vdb.read(str(sphere), "surface"), c, 0.02)
    z = (np.arange(diff.shape[2]) + lo[2]) * 0.02
    north = near & (z > 0.9)[None, None, :]
    south = near & (z < 0.3)[None, None, :]
    assert diff[north].max() > 0.01, "detailed near the point"
    assert diff[south].max() < 0.002, "untouched out of its reach"


def test_streams_through_a_pipeline(tmp_path):
    """vdb_primitive -o - | vdb_detail - -o - | file: the same grid as going through files."""
    import subprocess
    prim = subprocess.run([tool("vdb_primitive"), "-q", "sphere", "--radius", "0.5",
                           "--voxel-size", "0.02", "-o", "-"], capture_output=True, check=True)
    args = ["--warp-amplitude", "0.02", "--warp-scale", "0.4"]
    piped = subprocess.run([tool("vdb_detail"), "-q", "-", "-o", "-", *args], input=prim.stdout,
                           capture_output=True, check=True)
    out = tmp_path / "piped.vdb"
    out.write_bytes(piped.stdout)
    src = tmp_path / "s.vdb"
    src.write_bytes(prim.stdout)
    via_files = detail(src, tmp_path / "f.vdb", *args)
    g = vdb.read(str(out), "surface")
    assert g.activeVoxelCount() == via_files.activeVoxelCount() > 0
    assert np.array_equal(dense(g)[1], dense(via_files)[1])


def test_blending_interpolates_parameters_without_blurring(patch, tmp_path):
    """A mask ramping from 0 (x < -0.3 m) to 1 (x > 0.3 m) blends orientation 0° into 90°:
    each side keeps its orientation, and the transition keeps the full detail height (the
    parameters are interpolated, not two detailed surfaces averaged)."""
    dx = 0.02
    n0, n1 = -110, 110
    x = (np.arange(n0, n1) * dx)
    w = np.clip((x + 0.3) / 0.6, 0, 1)
    w = w * w * (3 - 2 * w)
    arr = np.broadcast_to(w[:, None, None], (n1 - n0, n1 - n0, 60)).astype(np.float32).copy()
    mask = vdb.FloatGrid(0.0)
    mask.name = "mask"
    mask.transform = vdb.createLinearTransform(voxelSize=dx)
    mask.copyFromArray(arr, ijk=(n0, n0, -10))
    mask_file = tmp_path / "mask.vdb"
    vdb.write(str(mask_file), grids=[mask])
    blend_file = tmp_path / "blend.json"
    blend_file.write_text(json.dumps({"gabor_orientation": 90}))
    common = ["--gabor-amplitude", "0.02", "--gabor-frequency", "4", "--gabor-bandwidth", "1",
              "--gabor-orientation", "0", "--direction-axis", "1,0,0"]
    g = detail(patch, tmp_path / "b.vdb", *common, "--blend", str(blend_file),
               "--blend-mask", str(mask_file))
    h = heightmap(g, margin=0.2)  # columns are x from -1.8 m
    xs = -1.8 + np.arange(h.shape[0]) * dx
    left, right, mid = h[xs < -0.5], h[xs > 0.5], h[np.abs(xs) < 0.15]
    a_left, s_left = dominant_angle(left, dx, 4.0)
    a_right, s_right = dominant_angle(right, dx, 4.0)
    assert abs((a_left + 90) % 180 - 90) < 12 and s_left > 0.5, (a_left, s_left)
    assert abs(a_right - 90) < 12 and s_right > 0.5, (a_right, s_right)
    rms = lambda a: float(np.sqrt(np.mean((a - a.mean()) ** 2)))
    assert rms(mid) > 0.8 * min(rms(left), rms(right)), (rms(mid), rms(left), rms(right))
    # Blurring, the alternative: two detailed surfaces (0° and 90°) averaged by the mask. Its
    # transition loses height (two unlike patterns cancel in part); the blend's does not.
    h0 = heightmap(detail(patch, tmp_path / "o0.vdb", *common), margin=0.2)
    common90 = [a if a != "0" or common[i - 1] != "--gabor-orientation" else "90" for i, a in enumerate(common)]
    h90 = heightmap(detail(patch, tmp_path / "o90.vdb", *common90), margin=0.2)
    wx = np.clip((xs + 0.3) / 0.6, 0, 1)
    wx = (wx * wx * (3 - 2 * wx))[:, None]
    averaged = ((1 - wx) * h0 + wx * h90)[np.abs(xs) < 0.15]
    assert rms(mid) > 1.15 * rms(averaged), (rms(mid), rms(averaged))
    # The same from Python; a blend without a mask is refused.
    gp = rockvdb.detail(vdb.read(str(patch), "surface"), gabor_amplitude=0.02, warp_amplitude=0.0,
                        gabor_frequency=4, gabor_bandwidth=1, direction_axis=(1, 0, 0),
                        blend={"gabor_orientation": 90}, blend_mask=mask)
    assert np.array_equal(dense(gp)[1], dense(g)[1])
    one_line_error(run([tool("vdb_detail"), str(patch), "-o", str(tmp_path / "x.vdb"), *common,
                        "--blend", str(blend_file)]), 2, "--blend-mask")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"gabor_bandwidth": 3}))
    one_line_error(run([tool("vdb_detail"), str(patch), "-o", str(tmp_path / "x.vdb"), *common,
                        "--blend", str(bad), "--blend-mask", str(mask_file)]), 2,
                   "cannot vary in space")


def test_block_ids_are_carried(tmp_path):
    """A vdb_blocks tile keeps its block_id grid through vdb_detail: same topology as the new
    surface, the same set of blocks, and ids agreeing with the input near the surface."""
    tile = tmp_path / "tile.vdb"
    # (Equidimensional blocks are thick enough for the detail: none is cut or lost.)
    run([tool("vdb_blocks"), "-q", "--type", "equidimensional", "--tile-size", "4",
         "--point-radius", "0.25", "--voxel-size", "0.03", "--warp-amplitude", "0", "--seed", "5",
         "-o", str(tile)], check=True)
    out = tmp_path / "o.vdb"
    detail(tile, out, "--warp-amplitude", "0.02", "--gabor-amplitude", "0.02",
           "--gabor-frequency", "5", "--direction-curvature")
    grids = {g.name: g for g in vdb.readAll(str(out))[0]}
    assert set(grids) == {"surface", "block_id"}
    s, ids = grids["surface"], grids["block_id"]
    assert ids.activeVoxelCount() == s.activeVoxelCount()
    src = {g.name: g for g in vdb.readAll(str(tile))[0]}
    before = {it.value for it in src["block_id"].citerOnValues()}
    after = {it.value for it in ids.citerOnValues()}
    assert after == before
    sacc, iacc = src["surface"].getConstAccessor(), src["block_id"].getConstAccessor()
    agree = total = 0
    oacc = s.getConstAccessor()
    for it in ids.citerOnValues():
        if it.count != 1:
            continue
        v, _ = sacc.probeValue(it.min)
        if abs(v) < 0.015 and abs(oacc.getValue(it.min)) < 0.015:
            total += 1
            agree += iacc.getValue(it.min) == it.value
    assert total > 1000 and agree / total > 0.95, (agree, total)


def test_sample_12_ridges_along_the_ring_vary_with_its_skeleton(tmp_path):
    """samples/12_detail_skeleton.sh at 4 cm: the detail is there all round the ring (no
    stage amplitude: only the skeleton's) and 7x higher on its +x side than on its -x side, as
    the polyline's amplitudes say."""
    run_sample("12_detail_skeleton.sh", tmp_path, "0.04")
    assert (tmp_path / "detail_ring.png").stat().st_size > 10000
    plain = vdb.read(str(tmp_path / "detail_ring_plain.vdb"), "surface")
    ring = vdb.read(str(tmp_path / "detail_ring.vdb"), "surface")
    assert ring.gridClass == vdb.GridClass.LEVEL_SET
    diff, near, lo = displacement(plain, ring, 0.04)
    x = (np.arange(diff.shape[0]) + lo[0]) * 0.04
    east = diff[near & (x > 1.2)[:, None, None]]
    west = diff[near & (x < -1.2)[:, None, None]]
    assert west.mean() > 0.001, "detailed all round"
    assert east.mean() > 3 * west.mean(), (east.mean(), west.mean())
