# Compiler flags for the C library and its C tests, in one place: pycolfrag/_build.py
# reads CSTD, CWARN and COPT from here for the Python extension. -ffp-contract=off keeps
# results bitwise reproducible.
CC      ?= gcc
CSTD    := -std=c99
CWARN   := -Wall -Wextra -Wpedantic
COPT    := -O3 -ffp-contract=off -fno-math-errno
# Gravity, m/s^2, the default of cf_solver_def.g: its one home is pycolfrag/data/constants.json, which
# Python reads as pycolfrag.core.names.G; every build compiles the C default from it (pycolfrag/_build.py
# reads the same file), so the solver and the IMs in g cannot use two values.
CF_ROOT := $(dir $(lastword $(MAKEFILE_LIST)))..
CF_G_M_S2 := $(shell sed -n 's/^ *"g_m_s2": *\([0-9.eE+-]*\).*/\1/p' $(CF_ROOT)/pycolfrag/data/constants.json)
$(if $(CF_G_M_S2),,$(error csrc/flags.mk: no "g_m_s2" in pycolfrag/data/constants.json))
CDEFS   := -DCF_G_M_S2=$(CF_G_M_S2)
CFLAGS  := $(CSTD) $(CWARN) $(COPT) $(CDEFS)
SANFLAGS := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
LDLIBS  := -lm
