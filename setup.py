"""Builds the compiled core (petswarm_env/_core.py lists its modules) with Cython; everything else
is in pyproject.toml. ``pip install .`` / ``pip install -e .`` run it; in a checkout,
``python setup.py build_ext --inplace`` rebuilds the extensions beside their sources."""

import runpy

from Cython.Build import cythonize
from setuptools import Extension, setup

COMPILED = runpy.run_path("petswarm_env/_core.py")["COMPILED"]

# IEEE arithmetic exactly as the interpreter's: no fused multiply-add (a*b + c rounded once), no
# fast-math, so the compiled form gives the interpreted form's episodes bit for bit
C_FLAGS = ["-ffp-contract=off", "-fno-fast-math"]

setup(
    ext_modules=cythonize(
        [Extension(m, [m.replace(".", "/") + ".py"], extra_compile_args=C_FLAGS) for m in COMPILED],
        compiler_directives={
            "language_level": 3,
            "boundscheck": False,
            "wraparound": False,
            "initializedcheck": False,
            "embedsignature": True,
            "binding": True,  # compiled functions keep their Python signatures and docstrings
        },
        quiet=True,
    ),
)
