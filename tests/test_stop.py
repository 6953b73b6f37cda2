"""A run stopped from outside ends cleanly: SIGTERM (a cancelled CI job, ``timeout``) as Ctrl-C.

The trace is closed and indexed (mcap's own reader reads its summary), the candump log
ends on a whole line, the exit status says which signal, and one line on stderr says where
the run stopped and where its files are.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from mcap.reader import make_reader

pytestmark = pytest.mark.slow  # a subprocess run


def _started_run(out, *extra: str) -> subprocess.Popen:
    """``wheelleg run balance`` (60 s simulated, never reached) that has written frames already."""
    env = {**os.environ, "MUJOCO_GL": "disable"}
    proc = subprocess.Popen([sys.executable, "-m", "wheelleg.hil.cli", "run", "balance", "--duration", "60",
                             "--no-plot", "--out", str(out), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    log = out / "balance.log"
    deadline = time.monotonic() + 120  # start-up on a slow, loaded machine
    while time.monotonic() < deadline and proc.poll() is None:
        if log.exists() and log.stat().st_size > 20_000:  # past start-up: a few hundred frames written
            return proc
        time.sleep(0.05)
    proc.kill()
    raise AssertionError(f"the run wrote no frames: {proc.communicate()[1][-2000:]}")


@pytest.mark.parametrize("signum, status, words", [(signal.SIGTERM, 143, "SIGTERM"),
                                                    (signal.SIGINT, 130, "interrupted")])
@pytest.mark.parametrize("mode", [(), ("--realtime",)], ids=["lockstep", "realtime"])
def test_a_stopped_run_leaves_a_closed_trace_and_says_where_it_stopped(tmp_path, signum, status, words, mode):
    proc = _started_run(tmp_path, *mode)
    try:
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()  # a run that ignored the signal (one started with SIGINT ignored) does not outlive the test
    assert proc.returncode == status, err[-2000:]
    line = err.strip().splitlines()[-1]
    assert words in line and "s simulated" in line and str(tmp_path / "balance.mcap") in line, line
    with open(tmp_path / "balance.mcap", "rb") as f:
        summary = make_reader(f).get_summary()  # None (or an error) for a trace left without its summary
    assert summary is not None and summary.statistics.message_count > 0
    text = (tmp_path / "balance.log").read_text()
    assert text.endswith("\n") and text.count("\n") > 100
