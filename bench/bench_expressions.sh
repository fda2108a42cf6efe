#!/usr/bin/env bash
# Issue 22's measure: a generated text model of about 8,000 clauses of
# min/max/sqrt/square (Prospero-like: rows of glyphs made of circles and
# capsules, extruded into a slab; examples/expressions/make_examples.py),
# seen from above at 384 px, 1 spp, --shader implicit_normal, one thread:
# CPU seconds of the whole process with per-cell simplification (--accel
# bvh, the default) against the whole tape at every step (--accel none),
# alternating runs, medians; then bench_trace's evaluations per camera ray
# of both modes and the fraction of equal normals, at a quarter of the
# resolution (its path-traced columns would take long in the reference).
# Last, the organic model of bench/make_organic.py (about 700 clauses of exp,
# ln, sin, division and min) at 1024 x 1024, 1 spp, normals, on 2 threads.
#
#   bash bench/bench_expressions.sh [runs]      (default 3 alternating pairs)
#
# BUILD (default build/release), OUT (default out/bench_expressions), SHAPES
# (glyphs, default 140: 7,978 clauses), RES (default 384), ORGANIC_RES
# (default 1024).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD:-build/release}
out=${OUT:-out/bench_expressions}
runs=${1:-3}
mkdir -p "$out"
/usr/bin/python3 examples/expressions/make_examples.py \
  --shapes "${SHAPES:-140}" --output "$out"
scene="$out/slab_text.json"
res=${RES:-384}

cpu() {  # user+system CPU seconds of one render
  /usr/bin/time -f "%U %S" -o "$out/time.txt" "$build/ypathtrace" \
    --scene "$scene" --resolution "$res" --samples 1 --threads 1 --quiet \
    --shader implicit_normal --accel "$1" --output "$out/$1.png"
  awk '{ printf "%.2f\n", $1 + $2 }' "$out/time.txt"
}
median() { sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

: > "$out/bvh.txt"
: > "$out/none.txt"
for run in $(seq "$runs"); do
  cpu bvh >> "$out/bvh.txt"
  cpu none >> "$out/none.txt"
done
bvh=$(median < "$out/bvh.txt")
none=$(median < "$out/none.txt")
echo "| mode | CPU s (median of $runs) | runs |"
echo "|---|---|---|"
echo "| bvh (per-cell simplification) | $bvh | $(tr '\n' ' ' < "$out/bvh.txt")|"
echo "| none (whole tape) | $none | $(tr '\n' ' ' < "$out/none.txt")|"
awk -v a="$none" -v b="$bvh" 'BEGIN { printf "\nratio none / bvh: %.1fx\n", a / b }'
echo
# Evaluations per camera ray (points and intervals) and the fraction of
# equal normals, from one run of bench_trace on the same scene.
"$build/bench/bench_trace" --counts "" --resolution $((res / 4)) --samples 1 \
  --reference-limit 1000000 "$scene"

# The organic model (bench/make_organic.py: about 700 clauses of exp, ln,
# sin, division, min) at ORGANIC_RES (default 1024) square, 1 spp, primary
# rays and normals, on 2 threads: wall and CPU seconds of the whole process
# (scene load and the lazy octree included), median of $runs runs.
/usr/bin/python3 bench/make_organic.py --output "$out"
ores=${ORGANIC_RES:-1024}
: > "$out/organic.txt"
for run in $(seq "$runs"); do
  /usr/bin/time -f "%e %U %S" -o "$out/time.txt" "$build/ypathtrace" \
    --scene "$out/organic.json" --resolution "$ores" --samples 1 --threads 2 \
    --quiet --shader implicit_normal --output "$out/organic.png"
  cat "$out/time.txt" >> "$out/organic.txt"
done
wall=$(cut -d' ' -f1 "$out/organic.txt" | median)
cpu=$(awk '{ print $2 + $3 }' "$out/organic.txt" | median)
echo
echo "organic model, ${ores}x${ores}, 1 spp, 2 threads: wall ${wall} s, CPU ${cpu} s (median of $runs)"
