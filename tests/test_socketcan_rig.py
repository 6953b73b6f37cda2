"""The rig in lockstep over real SocketCAN (vcan0/vcan1) records what it records over
python-can's virtual bus, byte for byte (run inside ``bash ci/uml-vcan.sh`` where the
kernel has no CAN)."""
from __future__ import annotations

import argparse
import random

import pytest

from wheelleg.hil.bus import vcan
from wheelleg.hil.commands.run import execute

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
    virtual, virtual_checks, _ = _run("virtual", tmp_path / "virtual")
    real, real_checks, _ = _run("socketcan", tmp_path / "socketcan")
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


class _InFlightBus:
    """A virtual bus end whose frames are sometimes still "in flight": ``recv`` says
    nothing is there on a seeded coin flip, as a real socket may until the kernel has
    delivered. Frames stay in order per bus; across buses they arrive in any order."""

    def __init__(self, channel: str, seed: int):
        from wheelleg.hil.bus.transport import LockstepVirtualBus

        self.bus = LockstepVirtualBus(channel=channel, preserve_timestamps=True, receive_own_messages=False)
        self.rng = random.Random(seed)

    def recv(self, timeout=None):
        return None if self.rng.random() < 0.5 else self.bus.recv(0.0)

    def send(self, msg, timeout=None):
        self.bus.send(msg, timeout)

    def shutdown(self):
        self.bus.shutdown()


def test_late_delivery_on_either_bus_still_logs_the_virtual_bus_bytes(tmp_path, monkeypatch):
    """The rig's hold (hil/bus/held_bus.py) on a transport that delivers late: same bytes."""
    from dataclasses import replace

    from wheelleg.hil.run import rig as rig_module
    from wheelleg.hil import scenarios

    scenario = replace(scenarios.get("balance"), duration_s=0.4)
    expected = rig_module.Rig(scenario, rig_module.RigConfig(), tmp_path / "virtual").run()
    opened = iter(range(100))
    monkeypatch.setattr(rig_module, "_open_bus", lambda config, channel: _InFlightBus(channel, next(opened)))
    got = rig_module.Rig(scenario, rig_module.RigConfig(interface="in-flight"), tmp_path / "late").run()
    assert got.deadline_misses == 0
    assert got.log_path.read_bytes() == expected.log_path.read_bytes()
