# Only here because cffi_modules cannot live in pyproject.toml (see TOOLCHAIN.md).
from setuptools import setup

setup(cffi_modules=["pycolfrag/_build.py:ffibuilder"])
