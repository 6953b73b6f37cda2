"""Compiled bytecode for the suite's processes, kept out of the source tree.

A shell with ``PYTHONDONTWRITEBYTECODE=1`` (this project's development machine has it) keeps
``__pycache__`` folders out of the checkout, and so makes every process compile every module it
imports from source, every time: each xdist worker rewrote and compiled the ~100 test modules
to collect them (5.5 CPU s a worker, 2.0 s from bytecode) and each process a test starts
(``wheelleg run``, the CLI's exit-code tests, a campaign driver) compiled the rig again. The
suite writes its bytecode under the temporary folder instead (``PYTHONPYCACHEPREFIX``, which
mirrors each source's absolute path there): nothing lands in the tree, as the setting wants,
and the second run on is compiled once. A shell without the setting is left alone
(``__pycache__`` beside the sources, which .gitignore lists).
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

DONT_WRITE, PREFIX = "PYTHONDONTWRITEBYTECODE", "PYTHONPYCACHEPREFIX"


def default_prefix() -> str:
    """A per-user folder in the machine's temporary folder."""
    return str(Path(tempfile.gettempdir()) / f"wheelleg-hil-pycache-{os.getuid()}")


def outside_the_tree(environ) -> str | None:
    """Where bytecode goes when ``environ`` forbids writing it beside the sources (an explicit
    ``PYTHONPYCACHEPREFIX`` kept, else ``default_prefix()``); ``environ`` changed to say so, so
    the processes the tests start inherit it. None, ``environ`` untouched, if it does not forbid it."""
    if not environ.get(DONT_WRITE):
        return None
    prefix = environ.get(PREFIX) or default_prefix()
    environ[PREFIX] = prefix
    del environ[DONT_WRITE]
    return prefix
