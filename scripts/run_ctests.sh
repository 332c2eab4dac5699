#!/usr/bin/env bash
# Run every C test executable given, print their own summaries and a total line.
set -u
passed=0; failed=0; status=0
for t in "$@"; do
    out=$("$t" 2>&1); rc=$?
    echo "$out" | grep -v '^$'
    line=$(echo "$out" | grep -E '[0-9]+ passed, [0-9]+ failed' | tail -n 1)
    p=$(echo "$line" | sed -E 's/.* ([0-9]+) passed.*/\1/'); f=$(echo "$line" | sed -E 's/.* ([0-9]+) failed.*/\1/')
    [ -n "$p" ] || { p=0; f=1; echo "$t: crashed or printed no summary (exit $rc)"; }
    passed=$((passed + p)); failed=$((failed + f))
    [ $rc -eq 0 ] || status=1
done
echo "C tests: $passed passed, $failed failed"
exit $status
