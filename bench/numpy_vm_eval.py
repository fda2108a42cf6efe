#!/usr/bin/python3
"""A NumPy evaluator of .vm files, as in Keeter's Prospero challenge: each
clause is one vectorized operation over all points at once (float32).

Evaluates the file over the same grid as bench_tape (z = 0) and prints the
evaluations per second (best of --repeat runs, CPU time of this process) and
the mean value (bench_tape prints the same checksum).

Usage: bench/numpy_vm_eval.py FILE.vm [--grid N] [--repeat N]
"""
import sys
import time

import numpy as np

UNARY = {"neg": np.negative, "abs": np.abs, "square": np.square,
         "sqrt": np.sqrt, "exp": np.exp, "ln": np.log, "sin": np.sin,
         "cos": np.cos, "tan": np.tan, "asin": np.arcsin, "acos": np.arccos,
         "atan": np.arctan, "floor": np.floor, "ceil": np.ceil,
         "round": np.round, "not": lambda a: (a == 0).astype(np.float32)}
BINARY = {"add": np.add, "sub": np.subtract, "mul": np.multiply,
          "div": np.divide, "min": np.minimum, "max": np.maximum,
          "atan2": np.arctan2, "mod": lambda a, b: a - b * np.floor(a / b),
          "compare": lambda a, b: np.sign(a - b).astype(np.float32)}


def evaluate(lines, x, y, z):
    values = {}
    for line in lines:
        name, op, *args = line
        if op == "const":
            values[name] = np.float32(args[0])
        elif op in ("var-x", "var-y", "var-z"):
            values[name] = {"var-x": x, "var-y": y, "var-z": z}[op]
        elif op in UNARY:
            values[name] = UNARY[op](values[args[0]])
        else:
            values[name] = BINARY[op](values[args[0]], values[args[1]])
    return values[lines[-1][0]]


def main():
    args = sys.argv[1:]
    grid, repeat = 512, 3
    if "--grid" in args:
        grid = int(args[args.index("--grid") + 1])
    if "--repeat" in args:
        repeat = int(args[args.index("--repeat") + 1])
    if not args or not args[0].endswith(".vm"):
        sys.exit(__doc__)
    lines = [line.split() for line in open(args[0])
             if line.strip() and not line.startswith("#")]
    c = ((np.arange(grid, dtype=np.float32) + 0.5) / grid * 2 - 1)
    x, y = np.meshgrid(c, c)  # x along rows, as bench_tape's points
    x, y = x.ravel(), y.ravel()
    z = np.zeros_like(x)
    best = float("inf")
    with np.errstate(all="ignore"):
        for _ in range(repeat):
            start = time.process_time()
            result = evaluate(lines, x, y, z)
            best = min(best, time.process_time() - start)
    print(f"numpy: {len(lines)} clauses, {grid} x {grid} points: {best:.3f} s, "
          f"{grid * grid / best * 1e-6:.2f} M evaluations/s")
    print(f"mean value {np.mean(result, dtype=np.float64):.6f}")


if __name__ == "__main__":
    main()
