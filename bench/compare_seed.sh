#!/usr/bin/env bash
# Side by side with the seed's own program on the seed's scenes.
#
#   bash bench/compare_seed.sh [resolution] [samples] [runs] [ours]
#
# Renders ../shared/seed_scenes/tests/06_gridsdf and 07_sdfunction with the
# seed's program (../shared/peer/ypathtrace) and ours (default:
# build/release/ypathtrace), `--shader implicit`, at equal resolution and
# samples (defaults: 720 px, 32 spp, 1 run each), in our defaults and with
# the seed's sampling (--mis one --sampler random). Runs alternate seed /
# ours; each time is the whole process's wall time (start-up, loading and
# writing included), the best of the runs. Both programs use every core
# (the seed's can not do otherwise). Prints a markdown table of times and
# ratios (seed time / our time). Skips, with a message, when ../shared or
# the seed's program is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
resolution=${1:-720}
samples=${2:-32}
runs=${3:-1}
ours=$(realpath -m "${4:-build/release/ypathtrace}")
shared="$root/../shared"
seed="$shared/peer/ypathtrace"
scenes="$shared/seed_scenes/tests"
if [ ! -d "$shared" ] || [ ! -x "$seed" ] || [ ! -d "$scenes" ]; then
  echo "compare_seed: skipped: $shared (the seed's program and scenes) is absent"
  exit 0
fi
if [ ! -x "$ours" ]; then
  echo "compare_seed: $ours not found; build it first (cmake --build --preset release)" >&2
  exit 1
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

# Wall time of one command in seconds, run from the scene's folder.
wall() {
  local dir=$1
  shift
  local start end
  start=$(date +%s.%N)
  (cd "$dir" && "$@" >/dev/null 2>&1) || {
    echo "compare_seed: failed in $dir: $*" >&2
    exit 1
  }
  end=$(date +%s.%N)
  echo "$end - $start" | bc -l
}

best() { printf '%s\n' "$@" | sort -g | head -1; }

echo "## seed's program vs ours: ${resolution} px, ${samples} spp, best of ${runs}, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| scene | seed s | ours, seed's sampling s | ratio | ours, defaults s | ratio |"
echo "|---|---:|---:|---:|---:|---:|"
for name in 06_gridsdf 07_sdfunction; do
  dir="$scenes/$name"
  scene=$(cd "$dir" && ls ./*.json | head -1)
  common=(--scene "$scene" --shader implicit --resolution "$resolution" --samples "$samples")
  seed_times=() one_times=() two_times=()
  for ((r = 0; r < runs; r++)); do
    seed_times+=("$(wall "$dir" "$seed" "${common[@]}" --output "$out/seed.hdr")")
    one_times+=("$(wall "$dir" "$ours" "${common[@]}" --quiet --mis one --sampler random --output "$out/one.hdr")")
    seed_times+=("$(wall "$dir" "$seed" "${common[@]}" --output "$out/seed.hdr")")
    two_times+=("$(wall "$dir" "$ours" "${common[@]}" --quiet --output "$out/two.hdr")")
  done
  s=$(best "${seed_times[@]}")
  one=$(best "${one_times[@]}")
  two=$(best "${two_times[@]}")
  printf '| %s | %.2f | %.2f | %.1fx | %.2f | %.1fx |\n' "$name" "$s" "$one" \
    "$(echo "$s / $one" | bc -l)" "$two" "$(echo "$s / $two" | bc -l)"
done
