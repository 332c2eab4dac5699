# Compiler flags for the C library and its C tests, in one place: pycolfrag/_build.py
# reads CSTD, CWARN and COPT from here for the Python extension. -ffp-contract=off keeps
# results bitwise reproducible.
CC      ?= gcc
CSTD    := -std=c99
CWARN   := -Wall -Wextra -Wpedantic
COPT    := -O3 -ffp-contract=off -fno-math-errno
CFLAGS  := $(CSTD) $(CWARN) $(COPT)
SANFLAGS := -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
LDLIBS  := -lm
