#!/usr/bin/env bash
# Every SIMD width and the scalar build must give bitwise the same results:
# tests/c/result_hashes.c hashes every bit of 14 solver configurations (each contact
# model, planar, monolithic, two components, damping, a collapse, stiff joints), and of
# a batch of 11 runs of each (cf_solver_batch_run: amplitudes and record lengths that
# end at different steps, so lanes are refilled, collapses, a refused job), which it
# also runs as batches of every width the build and CPU have (1, 2, 4, 8 runs side by
# side) and requires bitwise equal to the same runs alone (it fails on a MISMATCH); then a
# column with titanium dowels and a two-column portal with an epistyle (their outputs and
# connector histories hashed too), alone and as batches (one run after the other);
# built four times:
#   default          the widest the CPU runs, chosen at run time (AVX-512 lanes across
#                    joints, AVX2 lanes across points, on a CPU that has them)
#   -DCF_FORCE_AVX2  at most AVX2 (what an AVX2 CPU without AVX-512 runs)
#   -DCF_FORCE_SSE2  SSE2 only (what any x86-64 CPU runs)
#   -DCF_NO_SIMD     the scalar reference
# and the four outputs must be identical. The builds use the flags of csrc/flags.mk
# (no -march: the wider paths are compiled by function attributes).
# Then the output must equal the stored tests/c/result_hashes.expected: a change of results (a new law,
# a reordered sum) fails CI until it is re-pinned on purpose, in the commit that makes the change and with
# its evidence: `bash scripts/check_result_hashes.sh --pin` writes the file anew.
set -euo pipefail
pin=0
if [ "${1:-}" = "--pin" ]; then pin=1; fi
cd "$(dirname "$0")/.."
cflags=$(make -s -f csrc/flags.mk -f - print-cflags <<'MK'
print-cflags: ; @echo $(CFLAGS)
MK
)
mkdir -p build
declare -A variants=([simd]="" [avx2]="-DCF_FORCE_AVX2" [sse2]="-DCF_FORCE_SSE2" [scalar]="-DCF_NO_SIMD")
for v in simd avx2 sse2 scalar; do
    # shellcheck disable=SC2086
    ${CC:-gcc} $cflags ${variants[$v]} -Icsrc -o "build/result_hashes_$v" tests/c/result_hashes.c csrc/*.c -lm
    if ! "build/result_hashes_$v" > "build/result_hashes_$v.txt"; then
        grep -h "MISMATCH\|failed" "build/result_hashes_$v.txt" || true
        echo "check_result_hashes: the $v build's batches differ from its single runs (lines above)"; exit 1
    fi
done
status=0
for v in avx2 sse2 scalar; do
    if ! diff build/result_hashes_simd.txt "build/result_hashes_$v.txt"; then
        echo "check_result_hashes: the default (widest SIMD) and the $v builds differ (lines above)"; status=1
    fi
done
if [ $status -ne 0 ]; then exit $status; fi
echo "check_result_hashes: default SIMD, AVX2, SSE2 and scalar builds give identical results, batches" \
     "of every width equal to single runs ($(wc -l < build/result_hashes_simd.txt) lines)"
expected=tests/c/result_hashes.expected
if [ $pin -eq 1 ]; then
    cp build/result_hashes_simd.txt "$expected"
    echo "check_result_hashes: pinned $expected anew (commit it with the change of results and its evidence)"
elif ! diff "$expected" build/result_hashes_simd.txt; then
    echo "check_result_hashes: the results differ from the stored $expected (lines above: < stored, > now)." \
         "A change of results on purpose is re-pinned with --pin in the commit that makes it."
    exit 1
else
    echo "check_result_hashes: every line equals the stored $expected"
fi
