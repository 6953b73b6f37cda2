"""The optional compiled record path (hil/fast/*.c); everything else is in pyproject.toml.

``optional=True``: without a C compiler the build skips the extension with a warning and the rig
runs its pure-Python path (``wheelleg.hil.fast``).
"""
from setuptools import Extension, setup

SOURCES = ["hil/fast/_framecore.c", "hil/fast/wire.c", "hil/fast/frames.c", "hil/fast/record_core.c", "hil/fast/sinks.c"]
setup(ext_modules=[Extension("wheelleg.hil.fast._framecore", SOURCES, depends=["hil/fast/framecore.h"],
                             optional=True)])
