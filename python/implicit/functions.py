"""Math on SDFs and numbers: `im.x`, `im.sin(...)`, `im.min(...)`.

Each function takes SDFs (shapes or math expressions) and numbers and
returns a math expression, written into the scene as an infix formula (the
renderer's grammar: README "Expressions"). Shapes enter as their distance,
so `sphere(1) + 0.05 * sin(20 * x)` displaces a sphere.
"""

from .sdf import _call, _math

x = _math(("var", "x"))
y = _math(("var", "y"))
z = _math(("var", "z"))


def sqrt(a):
    return _call("sqrt", a)


def sin(a):
    return _call("sin", a)


def cos(a):
    return _call("cos", a)


def tan(a):
    return _call("tan", a)


def asin(a):
    return _call("asin", a)


def acos(a):
    return _call("acos", a)


def atan(a):
    return _call("atan", a)


def atan2(y_, x_):
    """The angle of (x_, y_), as C's atan2(y, x)."""
    return _call("atan2", y_, x_)


def exp(a):
    return _call("exp", a)


def log(a):
    """The natural logarithm (NaN below 0: outside)."""
    return _call("log", a)


def floor(a):
    return _call("floor", a)


def ceil(a):
    return _call("ceil", a)


def square(a):
    return _call("square", a)


def min(a, b, *more):
    """The smallest of two or more values (of shapes: their union)."""
    return _call("min", a, b, *more)


def max(a, b, *more):
    """The largest of two or more values (of shapes: their intersection)."""
    return _call("max", a, b, *more)


def mod(a, b):
    """a - b * floor(a / b): in [0, |b|) (fidget's rem_euclid)."""
    return _call("mod", a, b)


def clamp(v, lo, hi):
    """min(max(v, lo), hi)."""
    return _call("clamp", v, lo, hi)


def mix(a, b, t):
    """a + (b - a) * t (GLSL's mix)."""
    return _call("mix", a, b, t)
