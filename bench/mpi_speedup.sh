#!/usr/bin/env bash
# MPI speed-up of ypathtrace on this machine (issue 23's measure):
#  1. PAIRS alternating rounds of one process x 1 thread, 2 ranks x 1
#     thread and one process x 2 threads; prints each round and the median
#     speed-ups (target for 2 ranks: >= 1.8x);
#  2. one run each of 1 process, 1, 2 and 4 ranks x 1 thread (4 ranks are
#     oversubscribed on 2 cores), with the CPU seconds of every rank and of
#     all processes (mpirun included).
# Every output must be byte-identical to the first (the script fails if not).
#
#   bash bench/mpi_speedup.sh [ypathtrace options]
#
# Default: examples/sdfunction at 480 px, 128 spp, 8 bounces (about 8 s on one
# core). PAIRS (default 5); YPATHTRACE names the binary (default
# build/release/ypathtrace). Wall-clock numbers mean something only on an
# idle machine: the load average is printed before and after.
set -euo pipefail
cd "$(dirname "$0")/.."
binary="$(realpath "${YPATHTRACE:-build/release/ypathtrace}")"
pairs="${PAIRS:-5}"
args=("$@")
if [ ${#args[@]} -eq 0 ]; then
  args=(--scene examples/sdfunction/sdfunction.json --resolution 480
    --samples 128 --bounces 8)
fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
echo "load average before: $(cut -d' ' -f1-3 /proc/loadavg)"

# run NAME RANKS [THREADS]: one render (RANKS 0: without mpirun; THREADS per
# process, default 1); sets `wall`, `cpu` (all processes) and `ranks_cpu`
# (each rank's user + system seconds).
run() {
  local name="$1" ranks="$2" threads="${3:-1}"
  rm -f "$out"/cpu.*
  local command=("$binary" "${args[@]}" --threads "$threads" --quiet
    --output "$out/$name.exr")
  local start end
  start=$(date +%s.%N)
  if [ "$ranks" -eq 0 ]; then
    /usr/bin/time -o "$out/total" -f "%U %S" \
      /usr/bin/time -o "$out/cpu.0" -f "%U %S" "${command[@]}" >/dev/null
  else
    # Each rank under its own `time`, named by its rank.
    /usr/bin/time -o "$out/total" -f "%U %S" mpirun -np "$ranks" \
      sh -c 'exec /usr/bin/time -o "$0/cpu.$OMPI_COMM_WORLD_RANK" -f "%U %S" "$@"' \
      "$out" "${command[@]}" >/dev/null
  fi
  end=$(date +%s.%N)
  wall=$(awk "BEGIN{printf \"%.2f\", $end - $start}")
  cpu=$(awk '{printf "%.2f", $1 + $2}' "$out/total")
  ranks_cpu=""
  for file in $(ls "$out"/cpu.* | sort -t. -k2 -n); do
    ranks_cpu="$ranks_cpu$(awk '{printf "%.2f", $1 + $2}' "$file") "
  done
  if [ ! -f "$out/first.exr" ]; then
    cp "$out/$name.exr" "$out/first.exr"
  elif ! cmp -s "$out/$name.exr" "$out/first.exr"; then
    echo "error: $name's image differs from the first run's" >&2
    exit 1
  fi
}

echo
echo "Alternating: 1 process x 1 thread, 2 ranks x 1 thread, and 1 process x 2"
echo "threads (what the two cores give without MPI)"
echo
echo "| round | 1 process wall s | 2 ranks wall s | speed-up | 2 ranks CPU s per rank | 2 threads wall s | speed-up |"
echo "|---|---|---|---|---|---|---|"
speedups=()
thread_speedups=()
median() {
  printf "%s\n" "$@" | sort -n |
    awk '{v[NR]=$1} END{print (NR%2 ? v[(NR+1)/2] : (v[NR/2]+v[NR/2+1])/2)}'
}
for pair in $(seq "$pairs"); do
  run single 0
  single_wall=$wall
  run ranks2 2
  speedup=$(awk "BEGIN{printf \"%.2f\", $single_wall / $wall}")
  speedups+=("$speedup")
  row="| $pair | $single_wall | $wall | ${speedup}x | $ranks_cpu"
  run threads2 0 2
  thread_speedup=$(awk "BEGIN{printf \"%.2f\", $single_wall / $wall}")
  thread_speedups+=("$thread_speedup")
  echo "$row| $wall | ${thread_speedup}x |"
done
echo
echo "median speed-up of 2 ranks: $(median "${speedups[@]}")x" \
  "(2 threads: $(median "${thread_speedups[@]}")x)"

echo
echo "| mode | wall s | CPU s per rank | CPU s, all processes | speed-up |"
echo "|---|---|---|---|---|"
base=""
for ranks in 0 1 2 4; do
  run "mode$ranks" "$ranks"
  [ -z "$base" ] && base=$wall
  name="$ranks ranks"
  [ "$ranks" -eq 1 ] && name="1 rank"
  [ "$ranks" -eq 0 ] && name="1 process (no mpirun)"
  speedup=$(awk "BEGIN{printf \"%.2f\", $base / $wall}")
  echo "| $name | $wall | $ranks_cpu| $cpu | ${speedup}x |"
done
echo
echo "(every output byte-identical)"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
