#!/usr/bin/env bash
# Speed-up of ypathtrace under mpirun on this machine: 1 process x 1 thread,
# 2 ranks x 1 thread, 1 process x 2 threads; wall-clock and CPU seconds
# (user + system, all processes: mpirun's own included), best of REPEAT runs.
# Checks that every output is byte-identical to the first.
#
#   bash bench/mpi_speedup.sh [ypathtrace options]
#
# Default: examples/materials at 320 px, 32 spp. YPATHTRACE names the binary
# (default build/release/ypathtrace), REPEAT the runs per mode (default 3).
set -euo pipefail
cd "$(dirname "$0")/.."
binary="${YPATHTRACE:-build/release/ypathtrace}"
repeat="${REPEAT:-3}"
args=("$@")
if [ ${#args[@]} -eq 0 ]; then
  args=(--scene examples/materials/materials.json --resolution 320 --samples 32)
fi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

# mode name, then the command prefix and the thread count.
run_mode() {
  local name="$1" threads="$2"
  shift 2
  local best_wall="" best_cpu=""
  for i in $(seq "$repeat"); do
    /usr/bin/time -o "$out/time" -f "%e %U %S" "$@" "$binary" "${args[@]}" \
      --quiet --threads "$threads" --output "$out/$name.exr" >/dev/null
    local times
    times=$(tail -1 "$out/time")
    local wall cpu
    wall=$(echo "$times" | awk '{print $1}')
    cpu=$(echo "$times" | awk '{print $2 + $3}')
    if [ -z "$best_wall" ] || awk "BEGIN{exit !($wall < $best_wall)}"; then best_wall=$wall; fi
    if [ -z "$best_cpu" ] || awk "BEGIN{exit !($cpu < $best_cpu)}"; then best_cpu=$cpu; fi
  done
  echo "$name $best_wall $best_cpu"
}

echo "| mode | wall s | CPU s | speed-up vs 1x1 |"
echo "|---|---|---|---|"
base=""
for mode in "1x1 1" "2x1 1 mpirun -np 2" "1x2 2"; do
  set -- $mode
  result=$(run_mode "$@")
  read -r name wall cpu <<<"$result"
  [ -z "$base" ] && base=$wall
  speedup=$(awk "BEGIN{printf \"%.2f\", $base / $wall}")
  echo "| $name | $wall | $cpu | ${speedup}x |"
done
cmp "$out/1x1.exr" "$out/2x1.exr" && cmp "$out/1x1.exr" "$out/1x2.exr" &&
  echo "(outputs byte-identical)"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
