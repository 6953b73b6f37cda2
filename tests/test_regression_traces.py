"""Every trace in tests/traces/ replays identically into today's controller.

A bug report's trace (an MCAP, or a robot's candump log, gzipped or not)
becomes a regression test by being copied here. When a change to the
controller is intended, ``wheelleg replay FILE --update FILE`` writes the new
reference (see tests/traces/README.md).
"""
from __future__ import annotations

from pathlib import Path

import pytest

from wheelleg.hil.cli import main

TRACES = Path(__file__).parent / "traces"
FILES = sorted(p for p in TRACES.iterdir() if p.suffix in (".mcap", ".log", ".gz"))


def test_there_are_regression_traces():
    assert FILES, f"no traces in {TRACES}"


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_trace_replays_identically(path, capsys):
    code = main(["replay", str(path)])
    captured = capsys.readouterr()
    assert code == 0, captured.out + captured.err
