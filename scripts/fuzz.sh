#!/usr/bin/env bash
# Build the fuzz preset (clang, libFuzzer, ASan + UBSan) and run every fuzz
# target, one after another, for N seconds each (default 60). Fails on any
# crash, sanitizer report, hang (an input over 10 s), leak or memory use over
# 2 GiB; the input that did it is left in build/fuzz/artifacts/<target>/.
#
# Usage: scripts/fuzz.sh [seconds] [target...]   (targets: fuzz/README.md)
# New inputs the fuzzers find go to build/fuzz/corpus/<target>/; the seeds
# in fuzz/corpus/<target>/ are only read.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
all=(fuzz_scene fuzz_expression fuzz_vm fuzz_sdfgen fuzz_skanti fuzz_vol fuzz_vdb fuzz_obj fuzz_ply
  fuzz_png fuzz_jpg fuzz_hdr fuzz_exr fuzz_tga fuzz_bmp)
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${all[@]}")
jobs=$(nproc 2>/dev/null || echo 2)

if command -v ccache >/dev/null && [ -z "${CMAKE_CXX_COMPILER_LAUNCHER:-}" ]; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache
fi
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$jobs"

# Leaks inside third-party libraries that we can not fix are listed, with
# the reason, in fuzz/lsan.supp.
export LSAN_OPTIONS="suppressions=$PWD/fuzz/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export ASAN_OPTIONS="${ASAN_OPTIONS:-}:detect_leaks=1"

failed=()
summary=()
for target in "${targets[@]}"; do
  binary=build/fuzz/fuzz/$target
  work=build/fuzz/corpus/$target
  artifacts=build/fuzz/artifacts/$target
  log=build/fuzz/logs/$target.log
  mkdir -p "$work" "$artifacts" "$(dirname "$log")"
  options=(-max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048
    -print_final_stats=1 -artifact_prefix="$artifacts/")
  [ -f "fuzz/$target.dict" ] && options+=(-dict="fuzz/$target.dict")
  echo "== $target: ${seconds}s"
  status=0
  "$binary" "${options[@]}" "$work" "fuzz/corpus/$target" >"$log" 2>&1 || status=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1 || true)
  corpus=$(grep -o 'corp: [0-9]*/[0-9]*[a-zA-Z]*' "$log" | tail -1 | cut -d' ' -f2 || true)
  summary+=("$(printf '%-12s %-6s execs %-10s corpus %s' "$target" \
    "$([ $status -eq 0 ] && echo ok || echo FAIL)" "${execs:-?}" "${corpus:-?}")")
  if [ $status -ne 0 ]; then
    failed+=("$target")
    tail -n 60 "$log"
  fi
done

echo "== fuzz summary (${seconds}s each; logs in build/fuzz/logs)"
printf '%s\n' "${summary[@]}"
if [ ${#failed[@]} -ne 0 ]; then
  echo "fuzz: FAILED: ${failed[*]} (inputs in build/fuzz/artifacts/)"
  exit 1
fi
