"""The firmware's Linux port as its own process on real SocketCAN (vcan0/vcan1; inside
``wheelleg vcan uml --`` where the kernel has no CAN): free-running it keeps the motors off
until the remote says otherwise and disables them on SIGTERM; with --sync the rig starts it and
runs balance, an offline wheel, a motor fault, a jump and the E-stops against it in lockstep."""
from __future__ import annotations

import argparse
import signal
import subprocess

import pytest

import vcan_helpers
from wheelleg.dbc import cybergear as cg
from wheelleg.hil import firmware_build
from wheelleg.hil.bus import vcan
from wheelleg.hil.commands.run import execute

pytestmark = pytest.mark.socketcan
CHANNELS = {"vcan0": "can1", "vcan1": "can2"}


@pytest.fixture(scope="module")
def program(tmp_path_factory):
    reason = vcan.unavailable_reason()
    if reason is not None:
        pytest.fail(reason)
    return firmware_build.build("linux", tmp_path_factory.mktemp("fw"))


def _start(program, *flags):
    proc = subprocess.Popen([str(program), *flags, "vcan0", "vcan1"], stderr=subprocess.PIPE, text=True)
    said = proc.stderr.readline()
    assert "wheelleg-fw: running on vcan0/vcan1" in said, said
    return proc


def test_free_running_it_keeps_the_motors_off_and_disables_them_on_sigterm(program):
    wheels, joints = vcan_helpers.open_bus("vcan0"), vcan_helpers.open_bus("vcan1")
    proc = _start(program)
    try:
        seen = vcan_helpers.drain(joints, 200, timeout_s=2.0) + vcan_helpers.drain(wheels, 20, timeout_s=2.0)
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    assert "motors disabled" in err
    ids = {m.arbitration_id for m in seen}
    stops = {cg.request_id(cg.T_STOP, 0xFD, motor) for motor in (1, 2, 3, 4)}
    assert stops <= ids and 0x200 in ids  # no remote: E-stop, every joint stopped, zero current
    assert not ids - stops - {0x200}, sorted(map(hex, ids))  # no SYNC, no heartbeat, no torque
    assert all(bytes(m.data) == bytes(8) for m in seen if m.arbitration_id == 0x200)
    wheels.shutdown()
    joints.shutdown()


# balance is cut to 2 s, the rest run whole: jump and estop are the longest the socketcan stage's
# budget holds (in user-mode-linux about 40 and 70 s; the five at full length: docs/firmware.md)
@pytest.mark.parametrize("scenario,duration", [("balance", 2.0), ("offline-wheel", None), ("motor-fault", None),
                                               ("jump", None), ("estop", None)])
def test_with_sync_the_rig_starts_it_and_runs_scenarios_in_lockstep(program, tmp_path, scenario, duration):
    """Balance, a wheel drive going silent, a CyberGear fault and the Reenable that clears it, a jump,
    E-stops from every mode: the rig starts the port (``--program 'wheelleg-fw --sync'``), ticks it on
    its SYNC and judges it by its own checks, heartbeat included (this port sends the whole heartbeat)."""
    args = argparse.Namespace(scenario=scenario, out=tmp_path, interface="socketcan", channel=list(CHANNELS),
                              seed=0, duration=duration, realtime=False, external_controller=False, no_plot=True,
                              program=f"{program} --sync")
    outcome, checks, run = execute(args)
    assert run.program["kind"] == "command" and run.program["command"].endswith("--sync vcan0 vcan1")
    said = (tmp_path / f"{scenario}.program.log").read_text()
    assert "motors disabled" in said, said  # it ran to the end and was stopped by the rig's SIGTERM
    assert outcome.deadline_misses == 0, said
    assert all(c.passed for c in checks), [f"{c.name}: {c.detail}" for c in checks]
