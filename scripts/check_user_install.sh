#!/usr/bin/env bash
# CI's install-as-a-user check: build the sdist, build a wheel from that sdist (python -m build does both,
# the wheel from the unpacked sdist, so a file the sdist lacks fails here), install the wheel into a bare venv
# (PyPI's packages, nothing of the checkout), then, outside the checkout, run what a new user runs first:
# `pycolfrag --help`, one simulation, a 4-run grid and `pycolfrag figures` on its file.
# Usage: bash scripts/check_user_install.sh   (needs the dev extra's `build`: make .venv/.dev)
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

"$PY" -m build --outdir "$WORK/dist" . > "$WORK/build.log" 2>&1 || { tail -40 "$WORK/build.log"; exit 1; }
python3 -m venv "$WORK/venv"
"$WORK/venv/bin/pip" install -q --disable-pip-version-check "$WORK"/dist/pycolfrag-*.whl
USER_PY="$WORK/venv/bin/python"

cd "$WORK"   # outside the checkout: only the installed package can be imported
"$WORK/venv/bin/pycolfrag" --help > help.txt
grep -q "record-checks" help.txt
"$USER_PY" - <<'EOF'
import pycolfrag as pcf
assert "site-packages" in pcf.__file__, pcf.__file__
rec = pcf.ground_motion.synthesize(6.5, 10.0, seed=1)
res = pcf.simulate(pcf.Column.parthenon(), rec.acc, rec.dt)
print(f"installed pycolfrag {pcf.__version__}: one simulation, u_top {res.u_top:.4f}, {res.n_steps} steps")
EOF
"$WORK/venv/bin/pycolfrag" grid --mw 6.5 7.5 --dist 5 10 --samples 1 --out grid.h5 --no-figures --no-progress
"$WORK/venv/bin/pycolfrag" figures grid.h5 --out figures --n-boot 10 > figures.txt
test -s figures/fig12_fragility_utop.png
echo "check_user_install: sdist -> wheel -> bare venv: --help, simulate, a 4-run grid and its figures ($(wc -l < figures.txt) files)"
