#!/usr/bin/env bash
# implicit crosscheck: render every case with ypathtrace and Blender Cycles,
# then print the per-region table. See README.md.
#
# Environment (defaults in brackets):
#   BUILD      build dir with ypathtrace and crosscheck_compare [build/release]
#   BLENDER    Blender 3.4 executable [blender]
#   OUT        output dir [tools/crosscheck/out]
#   CASES      cases to run [all of make_scenes.py]
#   BATCHES    independent renders (seeds) per side [8]
#   SPP_OURS   samples per pixel per batch, ours [1024]
#   SPP_CYCLES samples per pixel per batch, Cycles [512]
#   BOUNCES    path length limit, both renderers [16]
#   MIS        ypathtrace --mis [two, the default of ypathtrace]
#   SAMPLER    ypathtrace --sampler [sobol, the default of ypathtrace]
#   THREADS    threads per renderer [1]
#   SEED       first seed; batch k uses SEED + k [1000]
# Renders already in OUT are reused (delete them to rerun).
set -euo pipefail
cd "$(dirname "$0")/../.."
BUILD=${BUILD:-build/release}
BLENDER=${BLENDER:-blender}
OUT=${OUT:-tools/crosscheck/out}
CASES=${CASES:-matte emission metal metal_glossybsdf mirror plastic glass glass_tinted glass_rough glass_rough_ms transparent volumetric subsurface gltfpbr_metal env_matte env_metal}
BATCHES=${BATCHES:-8}
SPP_OURS=${SPP_OURS:-1024}
SPP_CYCLES=${SPP_CYCLES:-512}
BOUNCES=${BOUNCES:-16}
MIS=${MIS:-two}
SAMPLER=${SAMPLER:-sobol}
THREADS=${THREADS:-1}
SEED=${SEED:-1000}

python3 tools/crosscheck/make_scenes.py --out "$OUT"

# Cases that differ from another only on the Cycles side reuse our renders.
ours_case() {
  case $1 in
    metal_glossybsdf) echo metal ;;
    glass_rough_ms) echo glass_rough ;;
    *) echo "$1" ;;
  esac
}

for case in $CASES; do
  ours=$(ours_case "$case")
  ours_prefix=$OUT/ours_${ours}_mis${MIS}_${SAMPLER}_b${BOUNCES}
  cycles_prefix=$OUT/cycles_${case}_b${BOUNCES}
  if [[ ! -f ${ours_prefix}_$((BATCHES - 1)).exr ]]; then
    start=$SECONDS
    for ((k = 0; k < BATCHES; k++)); do
      "$BUILD/ypathtrace" --scene "$OUT/$ours.json" \
        --output "${ours_prefix}_$k.exr" --resolution 200 \
        --samples "$SPP_OURS" --bounces "$BOUNCES" --clamp 1e6 --mis "$MIS" \
        --sampler "$SAMPLER" \
        --seed $((SEED + k)) --threads "$THREADS" --quiet
    done
    echo "ours   $ours ($MIS, $SAMPLER): $BATCHES x $SPP_OURS spp in $((SECONDS - start)) s" >&2
  fi
  if [[ ! -f ${cycles_prefix}_$((BATCHES - 1)).exr ]]; then
    start=$SECONDS
    "$BLENDER" -b --factory-startup -noaudio -t "$THREADS" \
      -P tools/crosscheck/blender_render.py -- "$OUT/$case.cycles.json" \
      "$cycles_prefix" "$SPP_CYCLES" "$BATCHES" "$SEED" "$BOUNCES" \
      > "$cycles_prefix.log" 2>&1
    echo "cycles $case: $BATCHES x $SPP_CYCLES spp in $((SECONDS - start)) s" >&2
  fi
done

echo "| case | region | pixels | ours RGB | Cycles RGB | rel. diff | std. err. | z | worst channel ± s.e. |"
echo "|---|---|---:|---|---|---:|---:|---:|---:|"
for case in $CASES; do
  ours=$(ours_case "$case")
  ours_files=() cycles_files=()
  for ((k = 0; k < BATCHES; k++)); do
    ours_files+=("$OUT/ours_${ours}_mis${MIS}_${SAMPLER}_b${BOUNCES}_$k.exr")
    cycles_files+=("$OUT/cycles_${case}_b${BOUNCES}_$k.exr")
  done
  "$BUILD/crosscheck_compare" --mask "$OUT/regions.pgm" \
    --names "$OUT/regions.txt" --case "$case" --ours "${ours_files[@]}" \
    --ref "${cycles_files[@]}" \
    --png "$OUT/side_by_side_${case}_mis${MIS}_${SAMPLER}_b${BOUNCES}.png"
done

# One picture of a few cases for the README: ours | Cycles | |difference| x 4.
montage=()
for case in glass subsurface volumetric env_metal; do
  png=$OUT/side_by_side_${case}_mis${MIS}_${SAMPLER}_b${BOUNCES}.png
  [[ -f $png ]] && montage+=("$png")
done
if ((${#montage[@]} > 0)); then
  "$BUILD/crosscheck_compare" stack --output "$OUT/montage_mis${MIS}_${SAMPLER}.png" "${montage[@]}"
fi
