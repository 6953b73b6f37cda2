"""Fuzz: random and malformed frames on both buses into the controller, seeded.

Two levels: the bare ``Controller`` fed an upright robot's frames plus a
stream of garbage for a few seconds of controller time (fast, many seeds),
and the rig, where a faulty node on each bus (``wheelleg.hil.run.faults.garbage``) sends
malformed frames while the robot balances on the physics.
"""
import math
import random

import can
import numpy as np
import pytest
from controller_feed import Robot

from wheelleg.controller import constants as C
from wheelleg.controller import params as P
from wheelleg.controller.modes import ENABLED, Mode
from wheelleg.controller.state import CAN1, CAN2
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_bus
from wheelleg.hil.run import faults
from wheelleg.hil.run.scenario import Scenario
from wheelleg.hil.scenarios.basic import standing
from wheelleg.hil.scenarios.common import DEG, pitch_below, stand
from wheelleg.hil.scenarios.faults import controller_alive, fault_affected_frames, mode_never

SECONDS = 3.0
_DB1 = load_bus(CAN1)
# (id, extended, length) of every frame the controller reads, per bus
CONSUMED = {
    CAN1: [(m.frame_id, False, m.length) for m in _DB1.messages
           if m.name.startswith(("C620_Feedback_1", "C620_Feedback_2", "IMU_", "Operator"))],
    CAN2: [(cg.reply_id(cg.T_FEEDBACK, motor, C.CG_HOST_ID, 2), True, 8) for motor in (1, 2, 3, 4)],
}
OUT_OF_RANGE = [  # (bus, frame): a C620 reporting 40 A (field max 20 A), a zero quaternion
    (CAN1, can.Message(arbitration_id=0x201, data=bytes([0, 0, 0, 0, 0x7F, 0xFF, 0, 0]), is_extended_id=False)),
    (CAN1, can.Message(arbitration_id=0x100, data=bytes(8), is_extended_id=False)),
]


def malformed(rng: random.Random, bus: str) -> tuple[can.Message, bool]:
    """(frame, whether the controller must count it as bad): wrong DLC, out of range, remote or error frames."""
    fid, ext, length = rng.choice(CONSUMED[bus])
    kind = rng.randrange(5)
    if kind == 0:
        size = rng.choice([n for n in range(9) if n != length])
        return can.Message(arbitration_id=fid, is_extended_id=ext, data=rng.randbytes(size), check=False), True
    if kind == 1:  # the DLC field says one thing, the data another
        return can.Message(arbitration_id=fid, is_extended_id=ext, data=rng.randbytes(length),
                           dlc=(length + 1) % 9, check=False), True
    if kind == 2 and bus == CAN1:
        return rng.choice(OUT_OF_RANGE)[1], True
    if kind == 3:  # ignored, not counted: nothing in it to check
        return can.Message(arbitration_id=fid, is_extended_id=ext, is_remote_frame=True, dlc=length,
                           check=False), False
    return can.Message(arbitration_id=rng.getrandbits(29), is_error_frame=True, data=rng.randbytes(8),
                       check=False), False


def random_frame(rng: random.Random) -> can.Message:
    """Anything at all: any id, any length, standard or extended, even CAN FD sizes."""
    ext = rng.random() < 0.5
    size = rng.choice([0, 1, 4, 8, 8, 8, 12, 64])
    return can.Message(arbitration_id=rng.getrandbits(29 if ext else 11), is_extended_id=ext,
                       data=rng.randbytes(size), is_fd=size > 8, check=False)


def feed(robot: Robot, make, rng: random.Random, per_tick: int) -> tuple[list, int]:
    """Run SECONDS of controller time, ``per_tick`` extra frames on each bus before each tick.

    ``make(rng, bus) -> (frame, must_count)``; returns the tick results and how many must be counted bad.
    """
    results, must = [], 0
    for _ in range(round(SECONDS / P.CONTROL_PERIOD)):
        now = robot.tick_no * P.CONTROL_PERIOD
        for _ in range(per_tick):
            for bus in (CAN1, CAN2):
                msg, bad = make(rng, bus)
                robot.ctl.on_frame(msg, bus, now)
                must += bad
        results.append(robot.step())
    return results, must


def _motion_torques(result) -> list:
    return [cg.motion_torque(m.arbitration_id) for m in result.frames[CAN2]
            if m.is_extended_id and cg.comm_type(m.arbitration_id) == cg.T_MOTION]


@pytest.mark.parametrize("seed", range(5))
def test_malformed_frames_are_counted_and_change_nothing(seed):
    rng = random.Random(seed)
    robot = Robot()
    results, must = feed(robot, malformed, rng, per_tick=3)
    assert all(r.mode in ENABLED for r in results[5:])  # still balancing: nothing offline, nothing tripped
    assert all(r.report.offline_count == 0 for r in results[5:])
    assert must > 3000 and robot.ctl.bus.bad_frames == must  # every bad one counted, nothing else
    assert all(math.isfinite(t) for r in results for t in _motion_torques(r))


@pytest.mark.parametrize("seed", range(5))
def test_random_frames_leave_the_motors_disabled_or_balancing(seed):
    rng = random.Random(100 + seed)
    robot = Robot()
    results, _ = feed(robot, lambda r, bus: (random_frame(r), False), rng, per_tick=3)
    last = results[-1]
    if robot.ctl.mode in ENABLED:  # balancing: finite torques to every joint
        torques = _motion_torques(last)
        assert len(torques) == 4 and all(math.isfinite(t) and abs(t) <= P.HIP_TORQUE_LIMIT + 0.01 for t in torques)
    else:  # disabled: stops and zero current only
        assert not _motion_torques(last)
        assert bytes([m for m in last.frames[CAN1] if m.arbitration_id == 0x200][0].data) == bytes(8)
    assert robot.ctl.bus.frames > 2 * 3 * len(results)


@pytest.mark.slow
def test_the_rig_balances_through_a_faulty_node_on_each_bus(tmp_path):
    """Physics in the loop: 2000 garbage frames/s on each bus for 1.5 s, the robot never notices."""
    from wheelleg.hil.run.rig import Rig, RigConfig
    from wheelleg.hil.record.rundata import load_run

    junk = [a for bus in faults.BUSES for a in faults.garbage(bus, 0.5, 1.5, 2000.0)]
    scenario = Scenario("fuzz", "garbage on both buses", 2.2, standing(), timeline=(stand(), *junk),
                        checks=(pitch_below(2 * DEG, 0.5), mode_never(Mode.DISABLED, 0.3),
                                fault_affected_frames("fault_garbage", 5000), controller_alive()))
    outcome = Rig(scenario, RigConfig(seed=7), tmp_path).run()
    run = load_run(outcome.trace_path)
    failed = [f"{r.name}: {r.detail}" for r in (c(run) for c in scenario.checks) if not r.passed]
    assert not failed, failed
    hb = run.heartbeat
    assert np.count_nonzero(np.diff(hb["BadFrames"]) != 0) > 100  # the controller saw and counted them
