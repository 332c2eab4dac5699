#!/usr/bin/env bash
# The SIMD build and the scalar build (-DCF_NO_SIMD) must give bitwise the same
# results: tests/c/result_hashes.c hashes every bit of 12 solver configurations
# (each contact model, planar, monolithic, two components, damping, a collapse).
set -euo pipefail
cd "$(dirname "$0")/.."
cflags=$(make -s -f csrc/flags.mk -f - print-cflags <<'MK'
print-cflags: ; @echo $(CFLAGS)
MK
)
mkdir -p build
${CC:-gcc} $cflags -Icsrc -o build/result_hashes tests/c/result_hashes.c csrc/*.c -lm
${CC:-gcc} $cflags -DCF_NO_SIMD -Icsrc -o build/result_hashes_scalar tests/c/result_hashes.c csrc/*.c -lm
build/result_hashes > build/result_hashes.txt
build/result_hashes_scalar > build/result_hashes_scalar.txt
if diff build/result_hashes.txt build/result_hashes_scalar.txt; then
    echo "check_result_hashes: SIMD and scalar builds give identical results ($(wc -l < build/result_hashes.txt) configurations)"
else
    echo "check_result_hashes: SIMD and scalar builds differ (lines above)"; exit 1
fi
