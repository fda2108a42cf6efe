#!/usr/bin/env bash
# Regenerate the seed corpora in fuzz/corpus/ with the project's own savers
# (fuzz/make_corpus.cpp) plus the example scenes. Run after changing a
# format; the result is committed (small files only).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --preset fuzz >/dev/null
cmake --build build/fuzz --target fuzz_make_corpus
build/fuzz/fuzz/fuzz_make_corpus fuzz/corpus
cp examples/*/*.json fuzz/corpus/fuzz_scene/
