"""SDF expressions in the style of fogleman/sdf.

An expression is a tree in the project's JSON format (an `sdfunctions`
element: primitives, CSG operators and transforms; see README "Scenes"), so
what Python models is exactly what the renderer parses. Evaluation, bounds,
meshing and baking go through the renderer's own C++ code: the tree is
compiled once by the scene parser and cached.

Conventions, as fogleman/sdf except where noted:

- `box(size)` is centred with full size `size`; `|` union, `&` intersection,
  `-` difference; `.k(r)` on the right operand (or `k=`) makes the blend
  smooth (polynomial smooth minimum of radius r).
- `translate`, `rotate` (radians, about an axis), `scale` (uniform or per
  axis; like fogleman/sdf it stays a distance bound: distances are multiplied
  by the smallest factor), `orient`, `round` (`dilate`), `shell`.
- Y is up (the renderer's scenes and cameras are Y-up; fogleman/sdf uses Z):
  `UP == Y` is the axis of `torus`, `cylinder` and `plane`, the default axis
  of `rotate`, and what `orient` turns.
"""

import json
import math
import numbers
import os

import numpy as np

from . import _expression, _implicit

X = (1.0, 0.0, 0.0)
Y = (0.0, 1.0, 0.0)
Z = (0.0, 0.0, 1.0)
UP = Y
ORIGIN = (0.0, 0.0, 0.0)

# Grid files by extension (the library's grid writers).
_GRID_EXTENSIONS = (".sdf", ".vdb", ".vol", ".df", ".vox2")


# -----------------------------------------------------------------------------
# VALUE CHECKS
# -----------------------------------------------------------------------------


def _number(name, value):
    """A finite float, or ValueError/TypeError naming the parameter."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a number, found {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name}: must be finite, found {value!r}")
    return value


def _positive(name, value):
    value = _number(name, value)
    if not value > 0:
        raise ValueError(f"{name}: must be > 0, found {value!r}")
    return value


def _non_negative(name, value):
    value = _number(name, value)
    if not value >= 0:
        raise ValueError(f"{name}: must be >= 0, found {value!r}")
    return value


def _vec3(name, value):
    """Three finite floats; a scalar is repeated."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        value = (value, value, value)
    array = np.asarray(value, dtype=object).reshape(-1)
    if array.shape != (3,):
        raise ValueError(f"{name}: expected 3 numbers, found {value!r}")
    return np.array([_number(name, v) for v in array], dtype=np.float64)


def _positive_vec3(name, value):
    v = _vec3(name, value)
    if not (v > 0).all():
        raise ValueError(f"{name}: must be > 0 in every component, found "
                         f"{tuple(v)}")
    return v


def _unit(name, value):
    v = _vec3(name, value)
    n = np.linalg.norm(v)
    if not n > 0:
        raise ValueError(f"{name}: must not be the zero vector")
    return v / n


def _floats(v):
    return [float(x) for x in v]


# -----------------------------------------------------------------------------
# MATRICES (4x4, float64, world_from_local)
# -----------------------------------------------------------------------------


def translation(offset):
    """4x4 matrix moving points by `offset`."""
    m = np.eye(4)
    m[:3, 3] = _vec3("offset", offset)
    return m


def rotation(angle, vector=UP):
    """4x4 matrix rotating by `angle` radians about `vector` (right-handed)."""
    angle = _number("angle", angle)
    x, y, z = _unit("vector", vector)
    c, s = math.cos(angle), math.sin(angle)
    t = 1 - c
    m = np.eye(4)
    m[:3, :3] = [[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                 [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                 [t * x * z - s * y, t * y * z + s * x, t * z * z + c]]
    return m


def scaling(factor):
    """4x4 matrix scaling by a number or by (sx, sy, sz)."""
    f = _vec3("factor", factor)
    if not (f != 0).all():
        raise ValueError(f"factor: must not be 0, found {tuple(f)}")
    return np.diag([f[0], f[1], f[2], 1.0])


def orientation(axis):
    """4x4 rotation that turns UP (Y) into `axis`."""
    a = _unit("axis", axis)
    up = np.array(UP)
    d = float(np.dot(up, a))
    if d > 1 - 1e-12:
        return np.eye(4)
    if d < -1 + 1e-12:
        return rotation(math.pi, X)
    return rotation(math.acos(max(-1.0, min(1.0, d))), np.cross(up, a))


def _matrix(value):
    """A 4x4 affine matrix from a 4x4 or 3x4 array (rows), checked."""
    m = np.asarray(value, dtype=np.float64)
    if m.shape == (3, 4):
        m = np.vstack([m, [0, 0, 0, 1]])
    if m.shape != (4, 4) or not np.allclose(m[3], [0, 0, 0, 1]):
        raise ValueError("expected an affine 4x4 or 3x4 matrix")
    if not np.isfinite(m).all():
        raise ValueError("the matrix must be finite")
    if abs(np.linalg.det(m[:3, :3])) < 1e-12:
        raise ValueError("the matrix is singular")
    return m


def _frame12(m):
    """The JSON frame of a 4x4 matrix: x, y, z axes then origin."""
    return _floats(np.concatenate([m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3]]))


def _frame_matrix(frame):
    m = np.eye(4)
    f = np.asarray(frame, dtype=np.float64)
    for i in range(4):
        m[:3, i] = f[3 * i:3 * i + 3]
    return m


# -----------------------------------------------------------------------------
# EXPRESSIONS
# -----------------------------------------------------------------------------


class SDF:
    """A signed distance expression (immutable).

    Its JSON object in the scene format is what `to_json()` returns. Math
    expressions (`x + 2 * sphere(1)`) keep a syntax tree and become an
    `expression` object when first needed (_expression.py).
    """

    __slots__ = ("_node", "_k", "_compiled", "_tree", "_math")
    # NumPy scalars defer arithmetic with an SDF to the SDF's operators.
    __array_ufunc__ = None

    def __init__(self, node, k=None, *, math=False, tree=None):
        self._node = node
        self._k = k
        self._compiled = None
        self._tree = tree
        self._math = bool(math)

    def _json(self):
        """The JSON object (built from the syntax tree on first use)."""
        if self._node is None:
            self._node = _expression.to_node(self._tree)
        return self._node

    # ---- JSON ----

    def to_json(self):
        """The expression as an `sdfunctions` element (without material)."""
        return json.loads(json.dumps(self._json()))

    def __repr__(self):
        text = json.dumps(self._json())
        if len(text) > 120:
            text = text[:117] + "..."
        return f"SDF({text})"

    # ---- smooth blends ----

    def k(self, k=None):
        """A copy whose blends with it as the right operand are smooth."""
        return SDF(self._node, None if k is None else _positive("k", k),
                   math=self._math, tree=self._tree)

    # ---- CSG operators ----

    def __or__(self, other):
        return union(self, other)

    def __and__(self, other):
        return intersection(self, other)

    def union(self, *others, k=None):
        return union(self, *others, k=k)

    def intersection(self, *others, k=None):
        return intersection(self, *others, k=k)

    def difference(self, *others, k=None):
        return difference(self, *others, k=k)

    # ---- arithmetic (math expressions) ----

    def __add__(self, other):
        return _arithmetic("+", self, other)

    def __radd__(self, other):
        return _arithmetic("+", other, self)

    def __sub__(self, other):
        """Two shapes: their difference (fogleman/sdf). Otherwise, when a
        number or a math expression is involved: arithmetic."""
        if isinstance(other, SDF) and not self._math and not other._math:
            return difference(self, other)
        return _arithmetic("-", self, other)

    def __rsub__(self, other):
        return _arithmetic("-", other, self)

    def __mul__(self, other):
        return _arithmetic("*", self, other)

    def __rmul__(self, other):
        return _arithmetic("*", other, self)

    def __truediv__(self, other):
        return _arithmetic("/", self, other)

    def __rtruediv__(self, other):
        return _arithmetic("/", other, self)

    def __pow__(self, other):
        return _arithmetic("^", self, other)

    def __rpow__(self, other):
        return _arithmetic("^", other, self)

    def __neg__(self):
        return _math(("neg", _tree(self)))

    def __pos__(self):
        return self

    def __abs__(self):
        return _call("abs", self)

    # ---- transforms ----

    def transform(self, matrix):
        """Apply a 4x4 (or 3x4) affine world_from_local matrix."""
        m = _matrix(matrix)
        node = self._json()
        if node["type"] == "transform":
            # Fold consecutive transforms into one node.
            m = m @ _frame_matrix(node["world_from_local"])
            node = node["operand"]
        return SDF({"type": "transform", "operand": node,
                    "world_from_local": _frame12(m)}, self._k)

    def translate(self, offset):
        return self.transform(translation(offset))

    def rotate(self, angle, vector=UP):
        """Rotate by `angle` radians about `vector` through the origin."""
        return self.transform(rotation(angle, vector))

    def scale(self, factor):
        """Scale by a number or per axis; distances shrink by the smallest
        factor, so the result stays a bound (as fogleman/sdf)."""
        return self.transform(scaling(factor))

    def orient(self, axis):
        """Rotate so that UP (Y) points along `axis`."""
        return self.transform(orientation(axis))

    # ---- operators of the operator table ----

    def round(self, radius):
        """Grow by `radius` (edges become round): d - radius."""
        return _operator("round", self, radius=radius)

    dilate = round

    def shell(self, thickness):
        """A hollow shell of full `thickness` about the surface:
        |d| - thickness / 2 (our `onion` takes the half thickness)."""
        return _operator("onion", self,
                         thickness=_positive("thickness", thickness) / 2)

    def twist(self, k):
        """Turn about UP (Y) by k radians per unit of height."""
        return _operator("twist", self, k=k)

    def bend(self, k):
        """Turn about Z by k radians per unit along X."""
        return _operator("bend", self, k=k)

    def repeat(self, period, count=None):
        """Copies every `period` (a number or per axis; 0: not along that
        axis), without end or `count` copies on each side of the origin (an
        integer or per axis). JSON: `spacing` and `limit`."""
        keys = {"spacing": period}
        if count is not None:
            keys["limit"] = count
        return _operator("repeat", self,
                         {"spacing": "period", "limit": "count"}, **keys)

    def elongate(self, h):
        """Cut at the centre planes and pull apart by 2h (a number or per
        axis)."""
        return _operator("elongate", self, h=h)

    def mirror(self, axes):
        """Mirror the + side about the planes of `axes` ("x", "xz", ...)."""
        return _operator("mirror", self, axes=axes)

    def displace(self, displacement):
        """Add `displacement` (a formula over x, y, z: a string, a number
        or a math expression). A displacement that holds shapes is plain
        arithmetic, self + displacement."""
        if isinstance(displacement, str):
            text = displacement
        else:
            tree = _tree(displacement, "displacement")
            if _has_shapes(tree):
                return self + displacement
            text = _expression.to_infix(tree, None)
        return _operator("displace", self, expression=text)

    def bounded(self, bounds):
        """The inside of this function clipped to the box `bounds`
        ((xmin, ymin, zmin), (xmax, ymax, zmax)): what an expression whose
        zero set is unbounded (a gyroid) needs."""
        box = _box("bounds", bounds)
        node = self._json()
        if node["type"] != "expression" or "bounds" in node:
            node = {"type": "expression", "expression": "s",
                    "operands": {"s": node}}
        else:
            node = dict(node)
        node["bounds"] = box
        return SDF(node, self._k, math=self._math)

    # ---- the renderer's evaluator ----

    def compile(self):
        """The expression parsed by the renderer (cached)."""
        if self._compiled is None:
            node = dict(self._json())
            node["material"] = 0
            text = json.dumps({"asset": {"version": "4.2"},
                               "materials": [{}], "sdfunctions": [node]})
            self._compiled = _implicit.compile_sdf(text, "expression")
        return self._compiled

    @staticmethod
    def _points(points, name):
        """Points of shape (..., 3) as a contiguous (N, 3) array (float32
        stays float32, anything else becomes float64) and their shape."""
        p = np.asarray(points)
        if p.dtype == object or not (np.issubdtype(p.dtype, np.number)
                                     or p.dtype == bool):
            raise TypeError(f"{name}: the points must be numbers, found dtype "
                            f"{p.dtype}")
        if p.ndim == 0 or p.shape[-1] != 3:
            raise ValueError(f"{name}: expected points of shape (N, 3), "
                             f"found {p.shape}")
        if p.dtype != np.float32:
            p = p.astype(np.float64)
        return np.ascontiguousarray(p.reshape(-1, 3)), p.shape[:-1]

    def eval(self, points):
        """Distances at points of shape (..., 3): shape (...). float32
        points give float32, anything else float64 (computed in float32, as
        the renderer does). One tape, compiled once, evaluates every point,
        many points per pass."""
        flat, shape = self._points(points, "eval")
        return self.compile().eval(flat).reshape(shape)

    __call__ = eval

    def gradient(self, points):
        """Exact gradients (forward-mode derivatives of the renderer's tape)
        at points of shape (..., 3): shape (..., 3), not normalized; the dtype
        rule of eval()."""
        flat, shape = self._points(points, "gradient")
        return self.compile().gradient(flat).reshape(shape + (3,))

    def bounds(self):
        """((xmin, ymin, zmin), (xmax, ymax, zmax)) of the zero set, as the
        renderer computes it (infinite along unbounded axes)."""
        return self.compile().bounds()

    def _voxel(self, voxel, samples, pad, bounds):
        if voxel is not None:
            return _positive("voxel", voxel)
        samples = _positive("samples", samples)
        box = bounds if bounds is not None else self.bounds()
        size = np.asarray(box[1], dtype=np.float64) - np.asarray(box[0])
        if not np.isfinite(size).all():
            raise ValueError("the SDF is unbounded (a plane?): give bounds= "
                             "and voxel=")
        return float((np.prod(np.maximum(size, 1e-9)) / samples) ** (1 / 3))

    def mesh(self, voxel=None, *, samples=2**22, pad=2, bounds=None):
        """Triangle mesh of the surface: (vertices float32 (V, 3), faces
        int32 (F, 3)), counter-clockwise seen from outside. The SDF is baked
        on a grid of `voxel` (default: about `samples` voxels over the
        bounds) padded by `pad` voxels, then meshed by OpenVDB, as
        `ysdf bake` + `ysdf to-mesh`."""
        voxel = self._voxel(voxel, samples, pad, bounds)
        return self.compile().mesh(voxel, int(pad), bounds)

    def save(self, path, voxel=None, *, samples=2**22, pad=2, bounds=None):
        """Mesh the surface and save it: .obj, .ply (the library's writers)
        or .stl (binary)."""
        path = str(path)
        ext = path[path.rfind("."):].lower() if "." in path else ""
        voxel = self._voxel(voxel, samples, pad, bounds)
        if ext in (".obj", ".ply"):
            self.compile().save_mesh(path, voxel, int(pad), bounds)
        elif ext == ".stl":
            vertices, faces = self.compile().mesh(voxel, int(pad), bounds)
            write_stl(path, vertices, faces)
        else:
            raise ValueError(f"{path}: unknown mesh extension (use .obj, .ply "
                             f"or .stl)")

    def save_vm(self, path):
        """Write the expression as a `.vm` file (fidget's format): math only,
        shared clauses written once; shapes and bounds have no opcode."""
        self.compile().save_vm(os.fspath(path))

    def save_grid(self, path, voxel, *, pad=2, bounds=None, binary=False):
        """Bake the SDF on a grid of `voxel` (as `ysdf bake`) and save it:
        .sdf (SDFGen text, or skanti binary with binary=True), .vdb, .vol."""
        path = str(path)
        ext = path[path.rfind("."):].lower() if "." in path else ""
        if ext not in _GRID_EXTENSIONS:
            raise ValueError(f"{path}: unknown grid extension (use "
                             f"{', '.join(_GRID_EXTENSIONS)})")
        if ext in (".df", ".vox2"):
            binary = True
        self.compile().save_grid(path, _positive("voxel", voxel), int(pad),
                                 bounds, bool(binary))


def _sdf(value, name="operand"):
    if not isinstance(value, SDF):
        raise TypeError(f"{name}: expected an SDF, found "
                        f"{type(value).__name__}")
    return value


# -----------------------------------------------------------------------------
# MATH EXPRESSIONS
# -----------------------------------------------------------------------------


def _math(tree):
    """A math expression from its syntax tree."""
    return SDF(None, math=True, tree=tree)


def _tree(value, name="operand"):
    """The syntax tree of an SDF (a shape becomes an operand) or a number."""
    if isinstance(value, SDF):
        if value._tree is not None:
            return value._tree
        return ("shape", value._json())
    return _expression.number(value, name)


def _arithmetic(op, a, b):
    return _math(("op", op, _tree(a), _tree(b)))


def _call(name, *args):
    return _math(("call", name, tuple(_tree(a, name) for a in args)))


def _has_shapes(tree):
    """Whether a syntax tree names a shape operand (explicit stack)."""
    stack = [tree]
    while stack:
        item = stack.pop()
        kind = item[0]
        if kind == "shape":
            return True
        if kind == "neg":
            stack.append(item[1])
        elif kind == "op":
            stack.extend(item[2:])
        elif kind == "call":
            stack.extend(item[2])
    return False


def _box(name, value):
    """((xmin, ymin, zmin), (xmax, ymax, zmax)) as JSON, each min < max."""
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected ((xmin, ymin, zmin), (xmax, "
                         f"ymax, zmax)), found {value!r}") from None
    a, b = _vec3(name, a), _vec3(name, b)
    if not (a < b).all():
        raise ValueError(f"{name}: each minimum must be below its maximum, "
                         f"found {tuple(a)} and {tuple(b)}")
    return [_floats(a), _floats(b)]


# -----------------------------------------------------------------------------
# THE OPERATOR TABLE (src/sdf/sdf_operator_table.h)
# -----------------------------------------------------------------------------

_OPERATORS = {row["name"]: row for row in _implicit.sdf_operators()}


def _counts(name, value, non_negative):
    """Three integers; one integer is repeated."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        value = (value, value, value)
    values = list(np.asarray(value, dtype=object).reshape(-1))
    if len(values) != 3 or any(isinstance(v, bool) or
                               not isinstance(v, numbers.Integral)
                               for v in values):
        raise TypeError(f"{name}: expected an integer or 3 integers, found "
                        f"{value!r}")
    if non_negative and min(values) < 0:
        raise ValueError(f"{name}: must be >= 0, found {value!r}")
    return [int(v) for v in values]


def _axes(name, value):
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected a string such as \"xz\", found "
                        f"{type(value).__name__}")
    if not value or any(c not in "xyz" for c in value) or \
            len(set(value)) != len(value):
        raise ValueError(f"{name}: expected distinct letters among x, y, z "
                         f"(e.g. \"xz\"), found {value!r}")
    return value


def _key_value(key, value):
    """A value for an operator key, checked by its type and range in the
    table (the loader checks it again, with the same rules)."""
    name, kind, limit = key["key"], key["type"], key["range"]
    if kind == "number":
        check = {"positive": _positive, "non_negative": _non_negative}
        return check.get(limit, _number)(name, value)
    if kind == "array of 3 numbers":
        v = _vec3(name, value)
        if limit == "positive" and not (v > 0).all():
            raise ValueError(f"{name}: must be > 0 in every component, "
                             f"found {tuple(v)}")
        if limit == "non_negative" and not (v >= 0).all():
            raise ValueError(f"{name}: must be >= 0 in every component, "
                             f"found {tuple(v)}")
        return _floats(v)
    if kind == "array of 3 integers":
        return _counts(name, value, limit != "any")
    if kind == "string of axes":
        return _axes(name, value)
    if kind == "string":
        if not isinstance(value, str) or not value:
            raise TypeError(f"{name}: expected a formula (a string)")
        return value
    raise TypeError(f"{name}: not a key Python sets")


def _operator(name, operand, labels=None, **values):
    """The object of operator `name` over `operand`, its keys checked by the
    operator table; `labels` names keys as the Python arguments do."""
    row = _OPERATORS[name]
    node = {"type": name, "operand": _sdf(operand)._json()}
    keys = {key["key"]: key for key in row["keys"]}
    for key, value in values.items():
        if key not in keys:
            raise TypeError(f"{name}: unknown key {key!r}")
        label = (labels or {}).get(key, key)
        node[key] = _key_value(dict(keys[key], key=label), value)
    for key in row["keys"]:
        if key["required"] and key["key"] not in node:
            raise TypeError(f"{name}: missing {key['key']!r}")
    return SDF(node, operand._k)


def _document_operators():
    """Append each operator's row of the table to its method's help."""
    methods = {"round": "round", "shell": "onion", "twist": "twist",
               "bend": "bend", "repeat": "repeat", "elongate": "elongate",
               "mirror": "mirror", "displace": "displace"}
    for method, name in methods.items():
        row = _OPERATORS[name]
        keys = "; ".join(f"{k['key']} ({k['type']}): {k['help']}"
                         for k in row["keys"] if k["key"] != "operand")
        function = getattr(SDF, method)
        function.__doc__ = (f"{function.__doc__}\n\n        Scene format: "
                            f"type \"{name}\", {row['help']}. Keys: {keys}.")


_document_operators()


def expression(text, *, bounds=None, **operands):
    """The formula `text` over x, y, z (README "Expressions"; `log` is the
    natural logarithm, `^` a power), whose other names are the shapes or
    expressions given as keywords: expression("s + 0.1*sin(9*x)", s=ball).
    The inside is where it is < 0; `bounds` clips it to a box."""
    if not isinstance(text, str):
        raise TypeError(f"expression: expected a string, found "
                        f"{type(text).__name__}")
    node = {"type": "expression", "expression": text}
    if operands:
        node["operands"] = {key: _sdf(value, key)._json()
                            for key, value in operands.items()}
    if bounds is not None:
        node["bounds"] = _box("bounds", bounds)
    try:
        _implicit.check_expression(text, list(operands))
    except _implicit.Error as error:
        raise _implicit.Error(f"expression: {error}") from None
    return SDF(node, math=True)


def load_vm(path, *, bounds=None):
    """A model in fidget's `.vm` format (one clause a line; the last is the
    value). The scene keeps the file's path (relative once saved)."""
    node = {"type": "expression", "uri": os.path.abspath(os.fspath(path))}
    if bounds is not None:
        node["bounds"] = _box("bounds", bounds)
    _implicit.check_vm(node["uri"])  # a missing or bad file fails here
    return SDF(node, math=True)



def _combine(kind, a, bs, k):
    """Fold operands left; plain steps extend one n-ary node, smooth ones
    (the right operand's .k()) nest a smooth node. With `k`, all operands
    form one smooth node, as the scene format reads an `operands` list: a
    smooth union folds its operands' values in increasing order at each
    point (the same for any order of the parts, and chained .k() parts of
    one blend are the same node), intersections pair neighbours into a
    balanced tree (the same as folding left for 2 and 3 operands), so that
    a blend of many parts prunes well and nests no deeper than one
    level."""
    node = _sdf(a)._json()
    if k is not None:
        k = _positive("k", k)
        if bs:
            return SDF({"type": "smooth_" + kind, "blend": k, "operands":
                        [node] + [_sdf(b)._json() for b in bs]})
    for b in bs:
        b = _sdf(b)
        blend = b._k
        if blend is not None:
            node = {"type": "smooth_" + kind, "operands": [node, b._json()],
                    "blend": blend}
        elif node["type"] == kind:
            # The parser folds operands left: ((a op b) op c) == [a, b, c].
            node = {"type": kind, "operands": node["operands"] + [b._json()]}
        else:
            node = {"type": kind, "operands": [node, b._json()]}
    return SDF(node)


def union(a, *bs, k=None):
    """a | b | ...: smooth with `k` or the operands' .k()."""
    return _combine("union", a, bs, k)


def intersection(a, *bs, k=None):
    """a & b & ..."""
    return _combine("intersection", a, bs, k)


def difference(a, *bs, k=None):
    """a - b - ...: b, ... removed from a."""
    return _combine("subtraction", a, bs, k)


# -----------------------------------------------------------------------------
# PRIMITIVES
# -----------------------------------------------------------------------------


def _placed(node, center):
    s = SDF(node)
    c = _vec3("center", center)
    return s.translate(c) if c.any() else s


def sphere(radius=1, center=ORIGIN):
    return _placed({"type": "sphere",
                    "radius": _positive("radius", radius)}, center)


def box(size=1, center=ORIGIN, a=None, b=None):
    """Box of full size `size` centred at `center`, or spanning corners
    `a` and `b`. (Our JSON `box` has its corner at the local origin.)"""
    if a is not None or b is not None:
        if a is None or b is None:
            raise ValueError("box: give both corners a and b")
        a, b = _vec3("a", a), _vec3("b", b)
        center, size = (a + b) / 2, np.abs(b - a)
    size = _positive_vec3("size", size)
    center = _vec3("center", center)
    s = SDF({"type": "box", "whd": _floats(size)})
    return s.translate(center - size / 2)


def rounded_box(size, radius, center=ORIGIN):
    """Box of full size `size` whose edges are rounded by `radius`
    (inside the size: radius <= min(size) / 2)."""
    half = _positive_vec3("size", size) / 2
    radius = _positive("radius", radius)
    if radius > half.min():
        raise ValueError(f"radius: must be <= half the smallest size "
                         f"{half.min()!r}, found {radius!r}")
    return _placed({"type": "rounded_box", "whd": _floats(half),
                    "radius": radius}, center)


def wireframe_box(size, thickness, center=ORIGIN):
    """The edges of a box of full size `size`: bars `thickness` wide, flush
    with the box's faces (inside it; fogleman/sdf centres them on the
    edges). The JSON `bbox` bars span 2 x its `thickness`."""
    return _placed({"type": "bbox",
                    "whd": _floats(_positive_vec3("size", size) / 2),
                    "thickness": _positive("thickness", thickness) / 2},
                   center)


box_frame = wireframe_box


def torus(r1, r2, center=ORIGIN):
    """Torus about UP (Y): ring radius r1, tube radius r2."""
    return _placed({"type": "torus", "r1": _positive("r1", r1),
                    "r2": _positive("r2", r2)}, center)


def _segment(kind, a, b, params):
    """A Y-axis primitive of half height |b - a| / 2 placed from a to b."""
    a, b = _vec3("a", a), _vec3("b", b)
    axis = b - a
    length = float(np.linalg.norm(axis))
    if not length > 0:
        raise ValueError(f"{kind}: a and b must differ")
    node = {"type": kind, "height": length / 2}
    node.update(params)
    s = SDF(node).orient(axis)
    center = (a + b) / 2
    return s.translate(center) if center.any() else s


def capsule(a, b, radius):
    """Capsule around the segment from a to b."""
    return _segment("capsule", a, b, {"radius": _positive("radius", radius)})


def capped_cylinder(a, b, radius):
    """Cylinder from a to b (flat caps)."""
    return _segment("cylinder", a, b, {"radius": _positive("radius", radius)})


def cylinder(radius, height, center=ORIGIN):
    """Cylinder along UP (Y) of full `height`, centred. (fogleman/sdf's
    cylinder is infinite; the renderer has only capped ones.)"""
    return _placed({"type": "cylinder",
                    "height": _positive("height", height) / 2,
                    "radius": _positive("radius", radius)}, center)


def capped_cone(a, b, ra, rb):
    """Cone from a (radius ra) to b (radius rb)."""
    ra, rb = _non_negative("ra", ra), _non_negative("rb", rb)
    if ra == 0 and rb == 0:
        raise ValueError("capped_cone: ra and rb cannot both be 0")
    return _segment("capped_cone", a, b, {"r1": ra, "r2": rb})


def ellipsoid(size, center=ORIGIN):
    """Ellipsoid with semi-axes `size` (a bound, not exact: IQ's)."""
    return _placed({"type": "ellipsoid",
                    "radii": _floats(_positive_vec3("size", size))}, center)


def octahedron(r, center=ORIGIN):
    """Regular octahedron |x| + |y| + |z| = r (exact distance)."""
    return _placed({"type": "octahedron", "radius": _positive("r", r)},
                   center)


def plane(normal=UP, point=ORIGIN):
    """Half space below the plane through `point` with normal `normal`."""
    s = SDF({"type": "plane"})
    n = _unit("normal", normal)
    if not np.allclose(n, UP, rtol=0, atol=0):
        s = s.orient(n)
    p = _vec3("point", point)
    return s.translate(p) if p.any() else s


def from_json(node):
    """An SDF from an `sdfunctions` element (its material and name are
    dropped); the renderer checks it when it is first used."""
    if not isinstance(node, dict) or "type" not in node:
        raise ValueError("expected an sdfunctions object with a type")
    node = {key: value for key, value in node.items()
            if key not in ("material", "name")}
    return SDF(json.loads(json.dumps(node)))


# -----------------------------------------------------------------------------
# MESH FILES
# -----------------------------------------------------------------------------


def write_stl(path, vertices, faces):
    """Binary STL of a triangle mesh (normals from the winding)."""
    v = np.asarray(vertices, dtype=np.float32)
    f = np.asarray(faces, dtype=np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ValueError("write_stl: expected vertices (V, 3) and faces "
                         "(F, 3)")
    tri = v[f]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.where(lengths > 0, normals / np.maximum(lengths, 1e-30), 0)
    record = np.dtype([("normal", "<f4", 3), ("vertices", "<f4", (3, 3)),
                       ("attribute", "<u2")])
    data = np.zeros(len(f), dtype=record)
    data["normal"] = normals
    data["vertices"] = tri
    _implicit.write_file(os.fspath(path),
                         b"implicit binary STL".ljust(80, b" ") +
                         np.uint32(len(f)).tobytes() + data.tobytes())
