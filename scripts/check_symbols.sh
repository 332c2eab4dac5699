#!/usr/bin/env bash
# Every symbol a csrc/<file>.c exports must start with cf_<file>_ (docs/architecture.md: names say
# where they live; REBOUND checks the same with nm). Private helpers are static.
set -euo pipefail
cd "$(dirname "$0")/.."
source_flags=$(make -s -f csrc/flags.mk -f - print-cflags <<'MK'
print-cflags: ; @echo $(CFLAGS)
MK
)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
bad=0
for c in csrc/*.c; do
    base=$(basename "$c" .c); base=${base#cf_}   # cf_common.c -> cf_common_
    ${CC:-gcc} $source_flags -Icsrc -c "$c" -o "$tmp/$base.o"
    while read -r sym; do
        case "$sym" in
            cf_${base}_*) ;;
            *) echo "check_symbols: $c exports '$sym' (expected prefix cf_${base}_)"; bad=1 ;;
        esac
    done < <(nm --defined-only -g "$tmp/$base.o" | awk '{print $3}')
done
[ $bad -eq 0 ] && echo "check_symbols: every exported symbol of csrc/<file>.c starts with cf_<file>_"
exit $bad
