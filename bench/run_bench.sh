#!/usr/bin/env bash
# Build the `bench` preset and run the benchmarks, printing markdown tables.
#
#   bash bench/run_bench.sh [bench_trace options]
#
# With no options: generated scenes of 1, 10, 100, 1,000 and 10,000
# primitives and the example scene, 256 pixels wide, 4 path samples per
# pixel. Other bench_* programs found in the build run after it with no
# arguments. BENCH_JOBS sets the build parallelism (default: 2).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset bench >/dev/null
cmake --build --preset bench --parallel "${BENCH_JOBS:-2}" >/dev/null
args=("$@")
if [ ${#args[@]} -eq 0 ]; then
  args=(--counts 1,10,100,1000,10000 examples/sdfunction/sdfunction.json)
fi
echo "## bench_trace ${args[*]}"
echo
build/bench/bench/bench_trace "${args[@]}"
for program in build/bench/bench/bench_*; do
  [ -x "$program" ] || continue
  [ "$(basename "$program")" = bench_trace ] && continue
  echo
  echo "## $(basename "$program")"
  echo
  "$program"
done
