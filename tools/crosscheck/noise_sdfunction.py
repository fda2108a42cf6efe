#!/usr/bin/env python3
# implicit crosscheck: noise per sample and time per sample of ypathtrace
# and Blender Cycles on examples/sdfunction, each against its own reference.
#
# Both renderers render the same scene (Cycles: make_sdfunction.py's
# meshes), the same path length (ypathtrace --bounces N, every Cycles bounce
# limit N - 2, see blender_render.py), no clamping, one thread each:
#   1. a reference of --ref-spp samples per renderer (kept in --out);
#   2. --runs renders of --spp samples with independent seeds, alternating
#      between the renderers; relMSE of each against its own reference
#      (crosscheck_compare relmse: mean of (x - ref)^2 / (ref^2 + 0.01));
#   3. CPU time of the render: the child process's user + system time, minus
#      the median of three 1-sample renders (start-up, loading, BVH);
# and prints, per renderer, the relMSE at --spp, the CPU time per sample per
# pixel, relMSE x samples (noise per sample: unbiased estimates fall as
# 1 / samples) and the CPU time to reach relMSE 1e-4 and 1e-3.
#
# Usage: python3 tools/crosscheck/noise_sdfunction.py [--build build/release]
#          [--blender blender] [--out tools/crosscheck/out/noise]
#          [--width 240] [--bounces 4] [--ref-spp 4096] [--spp 16]
#          [--runs 8] [--detail 5] [--ours-args "--lightsampler uniform"]
# Python 3 standard library only.

import argparse
import os
import resource
import shlex
import statistics
import subprocess
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(__file__), "../.."))
SCENE = os.path.join(ROOT, "examples/sdfunction/sdfunction.json")


def cpu_of(command):
    # Run a command; return the CPU time (user + system) it took.
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def ours(args, output, spp, seed):
    return [os.path.join(args.build, "ypathtrace"), "--scene", SCENE,
            "--output", output, "--resolution", str(args.width),
            "--samples", str(spp), "--bounces", str(args.bounces),
            "--clamp", "1e30", "--seed", str(seed), "--threads", "1",
            "--quiet"] + shlex.split(args.ours_args)


def cycles(args, prefix, spp, seed):
    return [args.blender, "-b", "--factory-startup", "-noaudio", "-t", "1",
            "-P", os.path.join(ROOT, "tools/crosscheck/blender_render.py"),
            "--", os.path.join(args.out, "sdfunction.cycles.json"), prefix,
            str(spp), "1", str(seed), str(args.bounces), str(args.detail)]


def relmse(args, reference, images):
    out = subprocess.run([os.path.join(args.build, "crosscheck_compare"),
                          "relmse", "--ref", reference] + images,
                         check=True, capture_output=True, text=True).stdout
    return [float(line.split()[-1]) for line in out.splitlines()[:-1]]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--build", default=os.path.join(ROOT, "build/release"))
    parser.add_argument("--blender", default="blender")
    parser.add_argument("--out", default=os.path.join(
        ROOT, "tools/crosscheck/out/noise"))
    parser.add_argument("--width", type=int, default=240)
    parser.add_argument("--bounces", type=int, default=4)
    parser.add_argument("--ref-spp", type=int, default=4096)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--runs", type=int, default=8)
    parser.add_argument("--detail", type=int, default=5)
    parser.add_argument("--ours-args", default="")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    subprocess.run([sys.executable, os.path.join(
        ROOT, "tools/crosscheck/make_sdfunction.py"), "--out", args.out,
        "--width", str(args.width)], check=True)
    tag = f"w{args.width}_b{args.bounces}"
    refs = {"ours": os.path.join(args.out, f"ours_ref_{tag}.exr"),
            "cycles": os.path.join(args.out, f"cycles_ref_{tag}_0.exr")}
    if not os.path.exists(refs["ours"]):
        seconds = cpu_of(ours(args, refs["ours"], args.ref_spp, 99991))
        print(f"(ours reference: {args.ref_spp} spp, {seconds:.0f} CPU s)")
    if not os.path.exists(refs["cycles"]):
        seconds = cpu_of(cycles(args, refs["cycles"][:-6], args.ref_spp, 99991))
        print(f"(Cycles reference: {args.ref_spp} spp, {seconds:.0f} CPU s)")
    run = {"ours": lambda out, spp, seed: ours(args, out + "_0.exr", spp, seed),
           "cycles": lambda out, spp, seed: cycles(args, out, spp, seed)}
    setup, seconds, images = {}, {}, {}
    for name in run:
        prefix = os.path.join(args.out, f"{name}_one")
        setup[name] = statistics.median(
            cpu_of(run[name](prefix, 1, 1)) for _ in range(3))
        seconds[name], images[name] = [], []
    for k in range(args.runs):
        for name in run:
            prefix = os.path.join(args.out, f"{name}_run{k}")
            seconds[name].append(
                cpu_of(run[name](prefix, args.spp, 1000 + k)) - setup[name])
            images[name].append(prefix + "_0.exr")
    pixels = args.width * round(args.width / 2.4)
    print(f"\nexamples/sdfunction, {args.width} px wide, {args.bounces} "
          f"bounces, {args.runs} runs of {args.spp} spp, references "
          f"{args.ref_spp} spp, one thread each\n")
    print("| renderer | relMSE at %d spp | CPU ns / sample / pixel | relMSE x "
          "spp | CPU s to relMSE 1e-3 | CPU s to relMSE 1e-4 |" % args.spp)
    print("|---|---|---|---|---|---|")
    for name in run:
        error = statistics.mean(relmse(args, refs[name], images[name]))
        per_sample = statistics.median(seconds[name]) / args.spp
        noise = error * args.spp
        print(f"| {name} | {error:.4g} | {1e9 * per_sample / pixels:.0f} | "
              f"{noise:.4g} | {noise * per_sample / 1e-3:.1f} | "
              f"{noise * per_sample / 1e-4:.0f} |")


main()
