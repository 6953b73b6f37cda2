"""The optional compiled record path (hil/fast/_framecore.c); everything else is in pyproject.toml.

``optional=True``: without a C compiler the build skips the extension with a warning and the rig
runs its pure-Python path (``wheelleg.hil.fast``).
"""
from setuptools import Extension, setup

setup(ext_modules=[Extension("wheelleg.hil.fast._framecore", ["hil/fast/_framecore.c"], optional=True)])
