#!/usr/bin/env bash
# Build the release configuration and run every test (the README's test command).
# With --sanitize, also build the debug configuration with ASan+UBSan and run
# the tests there.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)

# Formatting (STYLE.md): the sources must be as clang-format leaves them.
git ls-files '*.cpp' '*.h' | xargs clang-format --dry-run -Werror

cmake --preset release
cmake --build --preset release -j "$jobs"
ctest --preset release -j "$jobs"

if [ "${1:-}" = "--sanitize" ]; then
  cmake --preset debug
  cmake --build --preset debug -j "$jobs"
  ctest --preset debug -j "$jobs"
fi
