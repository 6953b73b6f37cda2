"""The rig's per-frame record path compiled: which implementation runs.

``_framecore`` (the C files here, a CPython extension built by ``pip install``
when a C compiler is at hand; optional, so the install succeeds without one)
does the recorder's wire model (``hil/bus/recorder.py``, ``wire_order.py``),
the candump lines (``hil/record/candump.py``), the ``/can/`` records
(``hil/record/can_batch.py``) and the float64 records (``float_records.py``)
without a Python object per frame beyond the ``Frame`` record the sinks get. The Python modules stay the reference and the
fallback: both give the same bytes (tests/test_framecore.py).

``WHEELLEG_PURE_PYTHON=1`` in the environment, or ``force_python(True)``,
makes every writer and recorder made afterwards use the Python path.
"""
from __future__ import annotations

import os
import warnings

VERSION = 1  # the C module's VERSION these Python callers expect

try:
    from . import _framecore  # this package's own compiled module
except ImportError:  # built without a compiler, or not built yet
    _framecore = None
if _framecore is not None and getattr(_framecore, "VERSION", None) != VERSION:
    warnings.warn("wheelleg.hil.fast: the built extension is from other sources; the rig runs its Python path "
                  "until it is rebuilt (pip install -e .)", RuntimeWarning, stacklevel=1)
    _framecore = None

ENV = "WHEELLEG_PURE_PYTHON"
_forced: bool | None = None


def force_python(on: bool | None) -> None:
    """True: the Python path for every recorder and writer made from now on; False: the compiled one
    when built; None: as ``WHEELLEG_PURE_PYTHON`` says."""
    global _forced
    _forced = on


def core():
    """The compiled module, or None when it is not built or the Python path is forced."""
    if _framecore is None:
        return None
    forced = _forced if _forced is not None else os.environ.get(ENV, "") not in ("", "0")
    return None if forced else _framecore


def available() -> bool:
    """Whether the compiled module is built (whatever is forced)."""
    return _framecore is not None
