"""Arithmetic on SDFs: the syntax trees behind `im.x + 2 * im.sphere(1)`.

A math expression is kept as a small tree of tuples until the renderer
needs it; then it becomes one `expression` object of the scene format: an
infix formula (the grammar of src/sdf/sdf_expression.h) whose shapes are
named operands:

    {"type": "expression", "expression": "s0 + 0.05*sin(20*x)",
     "operands": {"s0": {"type": "sphere", "radius": 1}}}

so that what Python builds is what a scene file holds, and the CLI renders a
saved scene exactly as Python does. A shape used twice is one operand (the
renderer evaluates it once). Trees are walked with explicit stacks: a sum of
ten thousand terms built in a loop is fine.

Tree nodes:
    ("num", value)             a finite float
    ("var", "x")               x, y or z
    ("op", "+", a, b)          + - * / ^
    ("neg", a)
    ("call", name, (a, ...))   a function of the infix grammar
    ("shape", node)            a scene-format object (a shape, or an
                               expression given as text or a .vm file)
"""

import math
import numbers

# Largest finite float32: the renderer reads numbers as 32-bit floats.
_FLOAT32_MAX = 3.4028234663852886e38

# Binding strength when written: + - < * / < unary minus < ^ < atoms.
_PRECEDENCE = {"+": 1, "-": 1, "*": 2, "/": 2, "^": 4}
_NEG = 3
_ATOM = 5


def number(value, name="value"):
    """A finite number that fits a 32-bit float, as a tree."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a number or an SDF, found "
                        f"{type(value).__name__}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name}: must be finite, found {value!r}")
    if abs(value) > _FLOAT32_MAX:
        raise ValueError(f"{name}: {value!r} is out of the range of 32-bit "
                         f"floats")
    return ("num", value)


def _precedence(tree):
    kind = tree[0]
    if kind == "op":
        return _PRECEDENCE[tree[1]]
    if kind == "neg" or (kind == "num" and math.copysign(1, tree[1]) < 0):
        return _NEG
    return _ATOM


def _format_number(value):
    # repr gives the shortest text that reads back as the same double; the
    # renderer rounds it to the nearest float, as it does scene numbers.
    text = repr(value)
    return text[:-2] if text.endswith(".0") else text


def to_infix(tree, name_of):
    """The infix text of a tree; `name_of(node)` names a shape operand.
    Parentheses keep the tree's own grouping (a + (b + c) stays so)."""
    out = []
    # Items: a tree with the least precedence it may have unparenthesized,
    # or a string to write as is.
    stack = [(tree, 0)]
    while stack:
        item, least = stack.pop()
        if isinstance(item, str):
            out.append(item)
            continue
        kind = item[0]
        paren = _precedence(item) < least
        if paren:
            out.append("(")
            stack.append((")", 0))
        if kind == "num":
            out.append(_format_number(item[1]))
        elif kind == "var":
            out.append(item[1])
        elif kind == "shape":
            out.append(name_of(item[1]))
        elif kind == "neg":
            out.append("-")
            stack.append((item[1], _NEG))
        elif kind == "op":
            op, a, b = item[1], item[2], item[3]
            own = _PRECEDENCE[op]
            # Left operands group left (a - b - c), so an equal right
            # operand needs parentheses; ^ groups right.
            left, right = (own + 1, own) if op == "^" else (own, own + 1)
            stack.append((b, right))
            stack.append((f" {op} " if own == 1 else op, 0))
            stack.append((a, left))
        else:  # call
            name, args = item[1], item[2]
            out.append(name + "(")
            stack.append((")", 0))
            for i in range(len(args) - 1, -1, -1):
                stack.append((args[i], 0))
                if i > 0:
                    stack.append((", ", 0))
    return "".join(out)


def to_node(tree):
    """The scene-format object of a tree: an `expression`, or the shape
    itself when the tree is one."""
    if tree[0] == "shape":
        return tree[1]
    names = {}
    operands = {}

    def name_of(node):
        key = id(node)
        if key not in names:
            names[key] = f"s{len(names)}"
            operands[names[key]] = node
        return names[key]

    node = {"type": "expression", "expression": to_infix(tree, name_of)}
    if operands:
        node["operands"] = operands
    return node
