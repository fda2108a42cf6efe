"""Math expressions in Python: the JSON they write (infix text, named
operands, the operator table's keys), the `-` rule, errors, .vm files and
saved scenes. Values against NumPy are in test_expression_values.py."""

import json
import os

import numpy as np
import pytest

import implicit as im


def formula(sdf):
    return sdf.to_json()["expression"]


# -----------------------------------------------------------------------------
# INFIX TEXT
# -----------------------------------------------------------------------------


def test_variables_numbers_and_operators():
    assert formula(im.x * im.x + im.y * im.y - 1) == "x*x + y*y - 1"
    assert formula(2 * im.x / 3) == "2*x/3"
    assert formula(1 - im.x) == "1 - x"
    assert formula(im.x ** 2) == "x^2"
    assert formula(2 ** im.x) == "2^x"
    assert formula(-im.x) == "-x"
    assert formula(+im.x) == "x"
    assert formula(abs(im.x - 1)) == "abs(x - 1)"
    assert formula(im.x * 0.05) == "x*0.05"
    assert formula(im.x + 1e-7) == "x + 1e-07"


def test_grouping_is_kept():
    # Parentheses where the tree groups otherwise than the grammar reads.
    assert formula(im.x - (im.y - im.z)) == "x - (y - z)"
    assert formula(im.x + (im.y + im.z)) == "x + (y + z)"
    assert formula((im.x + im.y) * im.z) == "(x + y)*z"
    assert formula(im.x / (im.y * im.z)) == "x/(y*z)"
    assert formula(-(im.x + im.y)) == "-(x + y)"
    assert formula(-(im.x * im.y)) == "-(x*y)"
    assert formula((-im.x) ** 2) == "(-x)^2"
    assert formula(-(im.x ** 2)) == "-x^2"
    assert formula((im.x ** 2) ** 3) == "(x^2)^3"
    assert formula(im.x ** (im.y ** 2)) == "x^y^2"
    assert formula(im.x ** -im.y) == "x^(-y)"
    assert formula(im.x - -0.5) == "x - -0.5"
    assert formula(im.x ** -0.5) == "x^(-0.5)"
    assert formula((-0.5) ** im.x) == "(-0.5)^x"


def test_functions():
    names = ["sqrt", "sin", "cos", "tan", "asin", "acos", "atan", "exp",
             "log", "floor", "ceil", "square"]
    for name in names:
        assert formula(getattr(im, name)(im.x)) == f"{name}(x)"
    assert formula(im.atan2(im.y, im.x)) == "atan2(y, x)"
    assert formula(im.min(im.x, im.y, 1)) == "min(x, y, 1)"
    assert formula(im.max(im.x, 2)) == "max(x, 2)"
    assert formula(im.mod(im.x, 0.5)) == "mod(x, 0.5)"
    assert formula(im.clamp(im.x, -1, 1)) == "clamp(x, -1, 1)"
    assert formula(im.mix(im.x, im.y, 0.25)) == "mix(x, y, 0.25)"
    # Functions of numbers alone are expressions too.
    assert formula(im.sqrt(2) * im.x) == "sqrt(2)*x"


def test_shapes_are_named_operands():
    ball = im.sphere(1)
    f = ball + 0.05 * im.sin(20 * im.x)
    node = f.to_json()
    assert node == {"type": "expression",
                    "expression": "s0 + 0.05*sin(20*x)",
                    "operands": {"s0": {"type": "sphere", "radius": 1.0}}}
    # One shape used twice is one operand; two shapes are two.
    g = ball * ball + im.box(1) - ball
    assert formula(g) == "s0*s0 + s1 - s0"
    assert set(g.to_json()["operands"]) == {"s0", "s1"}
    # Expressions nest in CSG and transforms like any shape.
    h = (f | im.box(2)).translate((1, 0, 0))
    assert h.to_json()["type"] == "transform"
    assert h.to_json()["operand"]["operands"][0]["type"] == "expression"


def test_long_sums_do_not_recurse():
    f = im.x
    for i in range(20000):
        f = f + i % 7
    text = formula(f)
    assert text.startswith("x + 0 + 1 + 2") and text.count("+") == 20000


def test_minus_of_two_shapes_stays_a_difference():
    a, b = im.sphere(1), im.box(1)
    assert (a - b).to_json()["type"] == "subtraction"
    # With a number or a math expression, minus is arithmetic.
    assert formula(a - 0.1) == "s0 - 0.1"
    assert formula(a - im.x) == "s0 - x"
    assert formula(im.x - a) == "x - s0"
    assert formula((a + 0) - b) == "s0 + 0 - s1"
    # Warped and transformed math is a shape again.
    assert ((im.x - 1).twist(1) - b).to_json()["type"] == "subtraction"


def test_numpy_scalars_work_on_either_side():
    assert formula(np.float32(0.5) * im.x) == "0.5*x"
    assert formula(im.x + np.float64(2)) == "x + 2"
    assert formula(np.int64(3) - im.x) == "3 - x"


# -----------------------------------------------------------------------------
# OPERATORS OF THE TABLE
# -----------------------------------------------------------------------------


def test_domain_operators_write_the_table_keys():
    ball = im.sphere(1)
    assert ball.twist(2).to_json() == {
        "type": "twist", "operand": {"type": "sphere", "radius": 1.0},
        "k": 2.0}
    assert ball.bend(-0.5).to_json()["k"] == -0.5
    r = ball.repeat(2).to_json()
    assert r["spacing"] == [2.0, 2.0, 2.0] and "limit" not in r
    r = ball.repeat((2, 0, 3), count=(1, 0, 4)).to_json()
    assert r["spacing"] == [2.0, 0.0, 3.0] and r["limit"] == [1, 0, 4]
    assert ball.repeat(1, count=2).to_json()["limit"] == [2, 2, 2]
    assert ball.elongate((0.5, 0, 1)).to_json()["h"] == [0.5, 0.0, 1.0]
    assert ball.mirror("xz").to_json()["axes"] == "xz"
    assert ball.round(0.1).to_json()["radius"] == 0.1
    assert ball.shell(0.2).to_json()["thickness"] == 0.1
    d = ball.displace(0.1 * im.sin(9 * im.x)).to_json()
    assert d["type"] == "displace" and d["expression"] == "0.1*sin(9*x)"
    assert ball.displace("0.2*cos(y)").to_json()["expression"] == \
        "0.2*cos(y)"
    # A displacement that holds a shape is arithmetic.
    assert ball.displace(0.1 * im.box(1)).to_json()["type"] == "expression"
    # The table's help is in the methods' docstrings.
    assert 'type "twist"' in im.SDF.twist.__doc__
    assert "opTwist" in im.SDF.twist.__doc__


def test_operator_arguments_are_checked():
    ball = im.sphere(1)
    with pytest.raises(ValueError, match=r"period: must be >= 0"):
        ball.repeat(-1)
    with pytest.raises(ValueError, match=r"count: must be >= 0"):
        ball.repeat(1, count=-1)
    with pytest.raises(TypeError, match=r"count: expected an integer"):
        ball.repeat(1, count=1.5)
    with pytest.raises(ValueError, match=r"h: must be >= 0"):
        ball.elongate(-1)
    with pytest.raises(ValueError, match=r"axes: expected distinct letters"):
        ball.mirror("xx")
    with pytest.raises(TypeError, match=r"axes: expected a string"):
        ball.mirror(1)
    with pytest.raises(TypeError, match=r"k: expected a number"):
        ball.twist("fast")
    with pytest.raises(ValueError, match=r"radius: must be > 0"):
        ball.round(0)
    # The loader refuses what Python would not write: spacing all zero.
    with pytest.raises(im.Error, match=r"spacing: must be > 0 on at least"):
        ball.repeat(0).bounds()


def test_bounded():
    f = (im.sin(im.x) + im.cos(im.y)).bounded(((-1, -1, -1), (1, 1, 1)))
    node = f.to_json()
    assert node["bounds"] == [[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]]
    assert node["expression"] == "sin(x) + cos(y)"
    shape = im.sphere(1).bounded(((0, 0, 0), (1, 1, 1))).to_json()
    assert shape["expression"] == "s" and shape["operands"]["s"]["type"] == \
        "sphere"
    with pytest.raises(ValueError, match="each minimum must be below"):
        im.x.bounded(((1, 0, 0), (0, 1, 1)))


# -----------------------------------------------------------------------------
# TEXT, FILES, ERRORS
# -----------------------------------------------------------------------------


def test_expression_text_and_errors():
    f = im.expression("s + 0.1*sin(9*x)", s=im.sphere(1))
    assert f.to_json()["operands"]["s"]["type"] == "sphere"
    assert formula(f * 2) == "s0*2"
    with pytest.raises(im.Error, match=r"^expression: column 10: expected "
                                       r"'\)'$"):
        im.expression("max(x, (y")
    with pytest.raises(im.Error, match=r'unknown function "foo"'):
        im.expression("foo(x)")
    with pytest.raises(im.Error, match=r"s: not used by the expression"):
        im.expression("x", s=im.sphere(1))
    with pytest.raises(im.Error, match=r"sin: not an operand name"):
        im.expression("x + sin", sin=im.sphere(1))
    with pytest.raises(TypeError):
        im.expression(3)
    with pytest.raises(ValueError, match="out of the range of 32-bit"):
        im.x + 1e39
    with pytest.raises(ValueError, match="must be finite"):
        im.x * float("nan")
    with pytest.raises(TypeError, match="expected a number or an SDF"):
        im.x + "y"


def test_vm_files(tmp_path):
    path = tmp_path / "ball.vm"
    path.write_text("# a ball\n_x var-x\n_y var-y\n_z var-z\n_a square _x\n"
                    "_b square _y\n_c square _z\n_s add _a _b\n"
                    "_t add _s _c\n_r sqrt _t\n_1 const 1\n_d sub _r _1\n")
    f = im.load_vm(path)
    assert f.to_json() == {"type": "expression", "uri": str(path)}
    # Written back: the same clauses (a parser-level round trip; values in
    # test_expression_values.py).
    out = tmp_path / "copy.vm"
    f.save_vm(out)
    assert out.read_text().startswith("# 11 clauses written by implicit")
    g = im.x * im.x + im.sqrt(im.y)
    g.save_vm(tmp_path / "g.vm")
    assert "sqrt" in (tmp_path / "g.vm").read_text()
    with pytest.raises(im.Error, match=r"holds a sphere node, which a \.vm "
                                       r"file cannot hold"):
        (im.sphere(1) + im.x).save_vm(tmp_path / "no.vm")
    bad = tmp_path / "bad.vm"
    bad.write_text("_x var-x\n_y foo _x\n")
    with pytest.raises(im.Error, match=r'bad\.vm:2: unknown opcode "foo"'):
        im.load_vm(bad)
    with pytest.raises(im.Error, match=r"missing\.vm: cannot open"):
        im.load_vm(tmp_path / "missing.vm")


def test_saved_scene_keeps_expressions(tmp_path):
    models = tmp_path / "models"
    models.mkdir()
    (models / "ball.vm").write_text("_x var-x\n_1 const 0.5\n_d sub _x _1\n")
    scene = im.Scene()
    scene.add((im.sphere(1) + 0.05 * im.sin(20 * im.x)).translate((1, 0, 0)),
              {"color": (0.5, 0.5, 0.5)})
    scene.add(im.load_vm(models / "ball.vm").bounded(((0, 0, 0),
                                                      (1, 1, 1))),
              {"color": (0.5, 0.5, 0.5)})
    scene.add(im.load_vm(models / "ball.vm") | im.sphere(1),
              {"color": (0.5, 0.5, 0.5)})
    scene.add_environment((1, 1, 1))
    folder = tmp_path / "out"
    folder.mkdir()
    scene.save(folder / "scene.json")
    data = json.loads((folder / "scene.json").read_text())
    first, second, third = data["sdfunctions"]
    assert first["operand"]["expression"] == "s0 + 0.05*sin(20*x)"
    # The .vm uri is relative to the saved file, however deep it is.
    assert second["uri"] == "../models/ball.vm"
    assert second["bounds"] == [[0, 0, 0], [1, 1, 1]]
    assert third["operands"][0]["uri"] == "../models/ball.vm"
    # The scene object itself keeps the absolute path.
    assert os.path.isabs(scene.sdfunctions[1]["uri"])
