"""SDF expressions: the renderer's evaluator against closed forms, bounds,
meshes, grids and argument checks."""

import math
import os

import numpy as np
import pytest

import implicit as im

RNG = np.random.default_rng(7)
POINTS = RNG.uniform(-3, 3, size=(500, 3))


def close(f, points, expected, atol=2e-5):
    """f at points equals `expected` (float32 evaluation, relative to
    scale)."""
    got = f.eval(np.asarray(points, dtype=np.float64))
    expected = np.asarray(expected, dtype=np.float64)
    scale = 1 + np.abs(expected)
    assert np.all(np.abs(got - expected) <= atol * scale), \
        np.max(np.abs(got - expected) / scale)


def length(v):
    return np.linalg.norm(v, axis=-1)


def centered_box(p, half):
    q = np.abs(p) - half
    return length(np.maximum(q, 0)) + np.minimum(q.max(axis=-1), 0)


def segment_distance(p, a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    h = np.clip(((p - a) @ (b - a)) / np.dot(b - a, b - a), 0, 1)
    return length(p - a - h[:, None] * (b - a))


# -----------------------------------------------------------------------------
# PRIMITIVES
# -----------------------------------------------------------------------------


def test_sphere():
    close(im.sphere(0.7), POINTS, length(POINTS) - 0.7)
    c = np.array([0.5, -1, 2])
    close(im.sphere(1.5, center=c), POINTS, length(POINTS - c) - 1.5)
    close(im.sphere(1), [[0, 0, 0], [2, 0, 0], [0, 0, -3]], [-1, 1, 2],
          atol=0)


def test_box_is_centred_with_full_size():
    size = np.array([1.0, 2.0, 3.0])
    close(im.box(size), POINTS, centered_box(POINTS, size / 2))
    close(im.box(2), [[0, 0, 0], [3, 0, 0], [2, 2, 2]],
          [-1, 2, math.sqrt(3)])
    c = np.array([1, 2, 3])
    close(im.box(1, center=c), POINTS, centered_box(POINTS - c, 0.5))
    close(im.box(a=(0, 0, 0), b=(2, 4, 6)), POINTS,
          centered_box(POINTS - [1, 2, 3], [1, 2, 3]))


def test_rounded_box():
    size, r = np.array([2.0, 1.0, 1.5]), 0.2
    close(im.rounded_box(size, r), POINTS,
          centered_box(POINTS, size / 2 - r) - r)


def test_wireframe_box():
    h, t = 1.0, 0.2
    f = im.wireframe_box(2 * h, t)
    # Along +x the nearest bars are those at x = h, |y| in [h - t, h].
    close(f, [[3, 0, 0]], [math.hypot(3 - h, h - t)])
    # On a bar, at the box's corner.
    close(f, [[h, h, h]], [0])
    close(f, [[h + 1, h, 0]], [1])


def test_torus_about_y():
    r1, r2 = 1.0, 0.25
    q = np.stack([np.hypot(POINTS[:, 0], POINTS[:, 2]) - r1, POINTS[:, 1]],
                 axis=-1)
    close(im.torus(r1, r2), POINTS, length(q) - r2)
    close(im.torus(r1, r2), [[1, 0, 0], [0, 0, 0]], [-r2, r1 - r2])


def test_capsule_between_points():
    a, b, r = (0, 0, 0), (0, 0.5, 2), 0.3
    close(im.capsule(a, b, r), POINTS, segment_distance(POINTS, a, b) - r)


def test_capped_cylinder_and_cylinder():
    f = im.capped_cylinder((-1, 0, 0), (1, 0, 0), 0.5)
    close(f, [[0, 0, 0], [2, 0, 0], [0, 2, 0], [2, 2, 0]],
          [-0.5, 1, 1.5, math.hypot(1, 1.5)])
    g = im.cylinder(0.5, 3)
    radial = np.hypot(POINTS[:, 0], POINTS[:, 2])
    d = np.stack([radial - 0.5, np.abs(POINTS[:, 1]) - 1.5], axis=-1)
    close(g, POINTS, np.minimum(d.max(axis=-1), 0) +
          length(np.maximum(d, 0)))


def test_capped_cone():
    f = im.capped_cone((0, 0, 0), (0, 2, 0), 1, 0.5)
    # Below the bottom cap, above the top one, and inside (nearest: the
    # slanted side through (1, 0) and (0.5, 2)).
    inside = abs(-1 * 2 + 1 * 0.5) / math.hypot(2, 0.5)
    close(f, [[0, -1, 0], [0, 3, 0], [0, 1, 0]], [1, 1, -inside])
    # Pointing along x: the same cone turned.
    g = im.capped_cone((0, 0, 0), (2, 0, 0), 1, 0.5)
    close(g, [[-1, 0, 0], [3, 0, 0], [1, 0, 0]], [1, 1, -inside])


def test_ellipsoid():
    radii = (1.0, 2.0, 0.5)
    close(im.ellipsoid(radii), [[2, 0, 0], [0, 4, 0], [0, 0, 1.5]],
          [1, 2, 1])
    close(im.ellipsoid(radii), [[0, 0, 0]], [-0.5])


def test_octahedron():
    r = 1.0
    close(im.octahedron(r), [[2, 0, 0], [0, 0, 0], [1, 1, 1]],
          [1, -r / math.sqrt(3), (3 - r) / math.sqrt(3)])


def test_plane():
    close(im.plane(), POINTS, POINTS[:, 1])
    n = np.array([1.0, 2.0, -2.0]) / 3
    p = np.array([0.5, 0.0, 1.0])
    close(im.plane(n, p), POINTS, (POINTS - p) @ n)


# -----------------------------------------------------------------------------
# OPERATORS AND TRANSFORMS
# -----------------------------------------------------------------------------


def smooth_min(a, b, k):
    """fogleman/sdf's smooth union."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0, 1)
    return b + (a - b) * h - k * h * (1 - h)


A = im.sphere(1)
B = im.box(1.5)
DA = length(POINTS) - 1
DB = centered_box(POINTS, 0.75)


def test_boolean_operators():
    close(A | B, POINTS, np.minimum(DA, DB))
    close(A & B, POINTS, np.maximum(DA, DB))
    close(A - B, POINTS, np.maximum(DA, -DB))
    C = im.sphere(0.5, center=(1, 0, 0))
    DC = length(POINTS - [1, 0, 0]) - 0.5
    close(A | B | C, POINTS, np.minimum(np.minimum(DA, DB), DC))
    close(A - B - C, POINTS, np.maximum(np.maximum(DA, -DB), -DC))
    close(im.union(A, B, C), POINTS, np.minimum(np.minimum(DA, DB), DC))


def test_smooth_operators():
    k = 0.25
    close(A | B.k(k), POINTS, smooth_min(DA, DB, k))
    close(im.union(A, B, k=k), POINTS, smooth_min(DA, DB, k))
    close(A & B.k(k), POINTS, -smooth_min(-DA, -DB, k))
    close(im.difference(A, B, k=k), POINTS, -smooth_min(-DA, DB, k))
    # Only the right operand's k counts, as in fogleman/sdf.
    close(A.k(k) | B, POINTS, np.minimum(DA, DB))


def test_smooth_union_of_many_is_one_group():
    # Five spheres in a row, k given: one node, whose value folds the smooth
    # minimum over the operands' values sorted at each point (not the
    # pairs ((0 1) (2 3)) 4 the list is stored as); chained .k() operands of
    # one blend are the same group, whatever their order.
    k = 0.4
    spheres = [im.sphere(0.5, center=(i, 0, 0)) for i in range(5)]
    d = [length(POINTS - [i, 0, 0]) - 0.5 for i in range(5)]
    blob = im.union(*spheres, k=k)
    assert blob._node["type"] == "smooth_union"
    assert len(blob._node["operands"]) == 5
    ordered = np.sort(np.stack(d), axis=0)
    group = ordered[0]
    for row in ordered[1:]:
        group = smooth_min(group, row, k)
    balanced = smooth_min(smooth_min(smooth_min(d[0], d[1], k),
                                     smooth_min(d[2], d[3], k), k), d[4], k)
    assert np.max(np.abs(balanced - group)) > 1e-3  # the test can tell
    close(blob, POINTS, group)
    chain = spheres[3]
    for s in spheres[4:] + spheres[:3]:
        chain = chain | s.k(k)
    close(chain, POINTS, group)


def test_round_and_shell():
    close(B.round(0.1), POINTS, DB - 0.1)
    close(B.dilate(0.1), POINTS, DB - 0.1)
    close(A.shell(0.2), POINTS, np.abs(DA) - 0.1)


def test_transforms():
    t = np.array([1.0, -2.0, 0.5])
    close(B.translate(t), POINTS, centered_box(POINTS - t, 0.75))
    # Rotation about y by 90 degrees takes +x to -z.
    f = im.box((2, 0.5, 0.5)).rotate(math.pi / 2, im.Y)
    close(f, [[0, 0, 1], [0, 0, -1], [1, 0, 0]], [0, 0, 0.75])
    # Default axis is UP.
    close(im.box((2, 0.5, 0.5)).rotate(math.pi / 2), [[0, 0, 1]], [0])
    close(A.scale(2), POINTS, 2 * (length(POINTS / 2) - 1))
    s = np.array([1.0, 2.0, 3.0])
    close(A.scale(s), POINTS, 1.0 * (length(POINTS / s) - 1))
    # Orient turns the torus' axis (Y) to X.
    close(im.torus(1, 0.25).orient(im.X), [[0, 1, 0], [0, 0, 1], [1, 0, 0]],
          [-0.25, -0.25, math.sqrt(2) - 0.25])
    # Consecutive transforms fold into one node, applied in order.
    g = A.scale(2).translate((3, 0, 0))
    assert g.to_json()["operand"]["type"] == "sphere"
    close(g, [[3, 0, 0], [6, 0, 0]], [-2, 1])


def test_eval_shapes_and_dtypes():
    f = im.sphere(1)
    assert f.eval(np.zeros((4, 3), np.float32)).dtype == np.float32
    assert f.eval(np.zeros((4, 3))).dtype == np.float64
    assert f.eval([[0, 0, 0]]).dtype == np.float64
    assert f.eval(np.zeros((2, 5, 3))).shape == (2, 5)
    assert f.eval(np.zeros(3)).shape == ()
    assert f(np.zeros((7, 3))).shape == (7,)
    assert f.eval(np.zeros((0, 3))).shape == (0,)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        f.eval(np.zeros((4, 2)))
    with pytest.raises(TypeError):
        f.eval([["a", "b", "c"]])


# -----------------------------------------------------------------------------
# BOUNDS, MESHES, GRIDS
# -----------------------------------------------------------------------------


def test_bounds():
    assert np.allclose(im.sphere(1, center=(1, 2, 3)).bounds(),
                       ((0, 1, 2), (2, 3, 4)))
    assert np.allclose(im.box((1, 2, 3)).bounds(),
                       ((-0.5, -1, -1.5), (0.5, 1, 1.5)))
    (lo, hi) = (A & B).bounds()
    assert np.all(np.array(lo) <= -0.75) and np.all(np.array(hi) >= 0.75)
    lo, hi = im.plane().bounds()
    assert math.isinf(lo[0]) and math.isinf(hi[0])


def test_mesh_vertices_lie_on_the_surface():
    f = (im.sphere(1) & im.box(1.5)) - im.cylinder(0.4, 3)
    voxel = 0.04
    vertices, faces = f.mesh(voxel)
    assert vertices.dtype == np.float32 and faces.dtype == np.int32
    assert len(vertices) > 1000 and faces.shape[1] == 3
    assert faces.min() >= 0 and faces.max() < len(vertices)
    assert np.abs(f.eval(vertices)).max() < voxel
    # Closed and outward: the divergence theorem gives the volume.
    tri = vertices[faces].astype(np.float64)
    volume = np.einsum("ij,ij->i", tri[:, 0],
                       np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    sphere = im.sphere(1).mesh(voxel)
    tri = sphere[0][sphere[1]].astype(np.float64)
    sphere_volume = np.einsum("ij,ij->i", tri[:, 0],
                              np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    assert abs(sphere_volume - 4 / 3 * math.pi) < 0.02 * 4 / 3 * math.pi
    assert 0 < volume < sphere_volume


def test_unbounded_mesh_needs_bounds():
    with pytest.raises(ValueError, match="unbounded"):
        im.plane().mesh(0.1)
    vertices, _ = (im.plane() & im.sphere(1)).mesh(
        0.1, bounds=((-1, -1, -1), (1, 1, 1)))
    assert len(vertices) > 0


def test_save_mesh_files(tmp_path):
    f = im.sphere(1)
    for name in ("s.obj", "s.ply", "s.stl"):
        f.save(tmp_path / name, voxel=0.1)
        assert os.path.getsize(tmp_path / name) > 1000
    data = (tmp_path / "s.stl").read_bytes()
    count = int.from_bytes(data[80:84], "little")
    assert len(data) == 84 + 50 * count
    with pytest.raises(ValueError, match="extension"):
        f.save(tmp_path / "s.xyz", voxel=0.1)


def test_save_grid(tmp_path):
    f = im.sphere(0.5)
    for name in ("g.sdf", "g.vdb", "g.vol"):
        f.save_grid(tmp_path / name, 0.05)
        assert os.path.getsize(tmp_path / name) > 100
    with pytest.raises(ValueError, match="extension"):
        f.save_grid(tmp_path / "g.txt", 0.05)


# -----------------------------------------------------------------------------
# ARGUMENT CHECKS
# -----------------------------------------------------------------------------


def test_bad_parameters():
    with pytest.raises(ValueError, match="radius"):
        im.sphere(-1)
    with pytest.raises(ValueError, match="finite"):
        im.sphere(float("nan"))
    with pytest.raises(ValueError, match="size"):
        im.box((1, 0, 1))
    with pytest.raises(ValueError, match="3 numbers"):
        im.box((1, 2))
    with pytest.raises(ValueError, match="radius"):
        im.rounded_box(1, 0.6)
    with pytest.raises(ValueError, match="k"):
        im.sphere(1).k(0)
    with pytest.raises(ValueError, match="must differ"):
        im.capsule((0, 0, 0), (0, 0, 0), 1)
    with pytest.raises(ValueError, match="singular"):
        im.sphere(1).transform(np.zeros((4, 4)) + np.eye(4) * [1, 1, 0, 1])
    with pytest.raises(TypeError):
        im.sphere(1) | 3
    with pytest.raises(ValueError, match="voxel"):
        im.sphere(1).mesh(-0.1)


def test_renderer_checks_json_it_did_not_make():
    f = im.from_json({"type": "sphere", "radius": -2})
    with pytest.raises(im.Error, match=r"expression: sdfunctions\[0\]"
                                       r"\.radius: must be > 0"):
        f.eval([[0, 0, 0]])
    g = im.from_json({"type": "torus", "r1": 1, "r2": 0.5, "name": "t"})
    close(g, [[1, 0, 0]], [-0.5])
