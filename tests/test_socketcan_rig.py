"""The rig in lockstep over real SocketCAN (vcan0/vcan1) records what it records over
python-can's virtual bus, byte for byte (run inside ``bash ci/uml-vcan.sh`` where the
kernel has no CAN)."""
from __future__ import annotations

import argparse

import pytest

from hil import vcan
from hil.commands.run import execute

DURATION_S = 2.0  # balance's pitch check starts at 1 s: 2 s gives it a window


def _run(interface: str, out):
    args = argparse.Namespace(scenario="balance", out=out, interface=interface, channels="vcan0,vcan1",
                              seed=0, duration=DURATION_S, realtime=False, external_controller=False,
                              no_plot=True)
    return execute(args)


@pytest.mark.socketcan
def test_balance_over_vcan_logs_the_same_bytes_as_over_virtual(tmp_path):
    reason = vcan.unavailable_reason()
    if reason is not None:
        pytest.fail(reason)
    virtual, virtual_checks = _run("virtual", tmp_path / "virtual")
    real, real_checks = _run("socketcan", tmp_path / "socketcan")
    assert real.deadline_misses == 0 and virtual.deadline_misses == 0
    expected, got = virtual.log_path.read_bytes(), real.log_path.read_bytes()
    assert len(expected) > 50_000  # ~1000 ticks of traffic, not an empty log
    if got != expected:
        want, have = expected.splitlines(), got.splitlines()
        first = next((i for i, (a, b) in enumerate(zip(want, have)) if a != b), min(len(want), len(have)))
        pytest.fail(f"candump logs differ from line {first + 1} ({len(want)} vs {len(have)} lines): "
                    f"virtual {want[first:first + 1]!r} vs socketcan {have[first:first + 1]!r}")
    assert [(c.name, c.passed) for c in real_checks] == [(c.name, c.passed) for c in virtual_checks]
    assert all(c.passed for c in real_checks), [f"{c.name}: {c.detail}" for c in real_checks]
