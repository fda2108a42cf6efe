"""f.gradient(points): the tape's forward-mode derivatives, all points through
one tape, against closed forms and central differences of f(points)."""

import numpy as np
import pytest

import implicit as im

RNG = np.random.default_rng(5)
POINTS = RNG.uniform(-2, 2, size=(500, 3))


def test_sphere_gradient_is_the_unit_direction():
    g = im.sphere(0.7).gradient(POINTS)
    assert g.shape == (500, 3) and g.dtype == np.float64
    expected = POINTS / np.linalg.norm(POINTS, axis=1, keepdims=True)
    np.testing.assert_allclose(g, expected, atol=1e-5)


def test_polynomial_gradient_is_exact():
    f = im.x * im.x + 3 * im.y * im.z - im.z
    g = f.gradient(POINTS.astype(np.float32))
    assert g.dtype == np.float32
    x, y, z = POINTS.T
    expected = np.stack([2 * x, 3 * z, 3 * y - 1], axis=1)
    np.testing.assert_allclose(g, expected, rtol=1e-5, atol=1e-5)


def test_gradient_matches_central_differences():
    f = im.union(im.sphere(1) + 0.1 * im.sin(5 * im.x) * im.cos(3 * im.y),
                 im.box(1, center=(0.8, 0, 0)), k=0.2)
    h = 1e-3
    g = f.gradient(POINTS)
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = h
        diff = (f(POINTS + step) - f(POINTS - step)) / (2 * h)
        # float32 values: differences carry about 1e-7 / 1e-3 of noise; the
        # box's edges are kinks, where a difference straddles two sides.
        close = np.abs(g[:, axis] - diff) <= 2e-3
        assert close.mean() >= 0.98


def test_gradient_keeps_the_leading_shape():
    g = im.sphere(1).gradient(POINTS.reshape(5, 100, 3))
    assert g.shape == (5, 100, 3)


def test_gradient_errors():
    with pytest.raises(ValueError, match="gradient: expected points"):
        im.sphere(1).gradient([1, 2])
    with pytest.raises(TypeError, match="gradient: the points must be numbers"):
        im.sphere(1).gradient([["a", "b", "c"]])
