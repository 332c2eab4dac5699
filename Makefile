# pycolfrag -- top-level Makefile: only delegates (set-up, build, tests, main job).
#   make test    set up (system + venv), run the C unit tests, then pytest
#   make grid    set up, run the paper's scenario grid on 2 MPI ranks, write figures
#   make build   rebuild the C extension after editing csrc/ (editable installs do not)
include csrc/flags.mk

PY      := .venv/bin/python
PIP     := .venv/bin/pip
CSRCS   := $(wildcard csrc/*.c)
CHDRS   := $(wildcard csrc/*.h)
CTESTS  := $(patsubst tests/c/%.c,build/ctest/%,$(wildcard tests/c/test_*.c))
CTESTS_ASAN := $(patsubst tests/c/%.c,build/ctest-asan/%,$(wildcard tests/c/test_*.c))
NRANKS  ?= 2
GRID_ARGS ?=
# Open MPI refuses root without these; set only for our own commands (TOOLCHAIN.md).
MPIENV  := OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1

.PHONY: setup system build ctest ctest-asan pytest test grid figures bench clean

setup: system .venv/.installed build

system:
	@bash scripts/setup_system.sh

.venv/.installed: pyproject.toml setup.py
	test -x $(PY) || python3 -m venv .venv
	$(PIP) install -q --upgrade pip setuptools wheel cffi
	$(PIP) install -q --no-build-isolation -e '.[dev]'
	touch $@

build: .venv/.built
.venv/.built: .venv/.installed $(CSRCS) $(CHDRS) pycolfrag/_build.py
	$(PIP) install -q --no-build-isolation --no-deps -e .
	touch $@

build/ctest/%: tests/c/%.c $(CSRCS) $(CHDRS) tests/c/cf_test.h
	@mkdir -p build/ctest
	$(CC) $(CFLAGS) -Icsrc -o $@ $< $(CSRCS) $(LDLIBS)

build/ctest-asan/%: tests/c/%.c $(CSRCS) $(CHDRS) tests/c/cf_test.h
	@mkdir -p build/ctest-asan
	$(CC) $(CSTD) $(CWARN) $(SANFLAGS) -ffp-contract=off -Icsrc -o $@ $< $(CSRCS) $(LDLIBS)

ctest: $(CTESTS)
	@bash scripts/run_ctests.sh $(CTESTS)

ctest-asan: $(CTESTS_ASAN)
	@bash scripts/run_ctests.sh $(CTESTS_ASAN)

pytest: setup
	$(PY) -m pytest -q

# The README's test command: everything, C tests first, pytest last (its summary closes the log).
test: setup ctest pytest

grid: setup
	mkdir -p results
	$(MPIENV) mpirun --allow-run-as-root -n $(NRANKS) $(PY) -m mpi4py scripts/run_grid.py $(GRID_ARGS)

figures: setup
	$(PY) scripts/make_figures.py results/grid.h5

bench: setup
	$(PY) bench/solver_speed.py
	$(PY) bench/ground_motion_speed.py

clean:
	rm -rf build pycolfrag/_libcolfrag*.so pycolfrag/_libcolfrag.c *.egg-info .venv/.built
