# Only here because cffi_modules cannot live in pyproject.toml.
from setuptools import setup

setup(cffi_modules=["pycolfrag/_build.py:ffibuilder"])
