"""The quadruped's operating modes: the MIT Cheetah's mode machine as a table.

Five modes, numbered as the remote's request (quadruped.dbc QuadOperator.Mode)
and the heartbeat's Mode. PASSIVE is the safe state: every motor in MIT mode
with kp = 0, a damping kd > 0 and no torque, so the legs fold slowly under
the body's weight instead of dropping limp. The others hold the legs with
joint PD (and feed-forward torque): STAND_UP (joint trajectory from lying
folded to the stand), BALANCE_STAND (all four feet down, body attitude and
height from the remote), LOCOMOTION (trot), RECOVERY_STAND (fold, roll onto
the belly, stand).

The E-stop and a missing or faulty device end every mode in PASSIVE and
latch it: the robot stays passive until the remote has asked for PASSIVE with
the E-stop released (``Inputs.armed``); an E-stop released with the switch
still on "walk" does not start the motors. The transitions are (from, condition,
to), checked in order; the first that holds is taken.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass


class Mode(enum.IntEnum):
    PASSIVE = 0  # damped joints, no torque: power-up, E-stop, faults, and on request
    STAND_UP = 1  # joint trajectory from lying folded to standing
    BALANCE_STAND = 2  # four feet down; body roll, pitch, yaw, height from the remote
    LOCOMOTION = 3  # trot at the remote's velocity and yaw rate
    RECOVERY_STAND = 4  # fold the legs, roll onto the belly, stand


ENABLED = frozenset({Mode.STAND_UP, Mode.BALANCE_STAND, Mode.LOCOMOTION, Mode.RECOVERY_STAND})
GETTING_UP = frozenset({Mode.STAND_UP, Mode.RECOVERY_STAND})
ON_FEET = frozenset({Mode.BALANCE_STAND, Mode.LOCOMOTION})
STANDING_REQUESTS = frozenset({Mode.STAND_UP, Mode.BALANCE_STAND, Mode.LOCOMOTION})


def requested_mode(value: int) -> Mode:
    """The remote's Mode field as a Mode; a value no mode has asks for PASSIVE."""
    try:
        return Mode(value)
    except ValueError:
        return Mode.PASSIVE


@dataclass(frozen=True)
class Inputs:
    """What the mode machine looks at each tick."""

    request: Mode  # the remote's requested mode
    estop: bool  # the remote's E-stop
    devices_ok: bool  # every motor, the IMU and the remote heard in time, no motor fault
    armed: bool  # no latched stop: the remote asked for PASSIVE since the last E-stop or fault
    upright: bool  # body z up, roll and pitch small: standing up needs no roll-over
    fallen: bool  # roll or pitch past the fall limits while on the feet
    motion_done: bool  # the stand-up or recovery trajectory has ended
    gait_settled: bool  # the trot, asked to stop, has all four feet down


def _may_start(i: Inputs) -> bool:
    return i.armed and i.devices_ok and not i.estop


# (from modes, condition, to). "*" means any mode.
TRANSITIONS: tuple = (
    ("*", lambda m, i: i.estop and m != Mode.PASSIVE, Mode.PASSIVE),
    ("*", lambda m, i: m in ENABLED and not i.devices_ok, Mode.PASSIVE),
    (tuple(ENABLED), lambda m, i: i.request == Mode.PASSIVE, Mode.PASSIVE),
    ((Mode.PASSIVE,), lambda m, i: _may_start(i) and i.request == Mode.RECOVERY_STAND, Mode.RECOVERY_STAND),
    ((Mode.PASSIVE,), lambda m, i: _may_start(i) and i.request in STANDING_REQUESTS and i.upright,
     Mode.STAND_UP),
    ((Mode.PASSIVE,), lambda m, i: _may_start(i) and i.request in STANDING_REQUESTS, Mode.RECOVERY_STAND),
    ((Mode.STAND_UP, Mode.BALANCE_STAND, Mode.LOCOMOTION), lambda m, i: i.request == Mode.RECOVERY_STAND,
     Mode.RECOVERY_STAND),
    ((Mode.STAND_UP, Mode.BALANCE_STAND, Mode.LOCOMOTION), lambda m, i: i.fallen, Mode.RECOVERY_STAND),
    (tuple(GETTING_UP), lambda m, i: i.motion_done and i.request in ON_FEET, Mode.BALANCE_STAND),
    ((Mode.BALANCE_STAND,), lambda m, i: i.request == Mode.LOCOMOTION, Mode.LOCOMOTION),
    ((Mode.LOCOMOTION,), lambda m, i: i.request in (Mode.BALANCE_STAND, Mode.STAND_UP) and i.gait_settled,
     Mode.BALANCE_STAND),
)


def next_mode(mode: Mode, inputs: Inputs) -> Mode:
    """The mode after this tick: the first transition from ``mode`` that holds."""
    for sources, condition, target in TRANSITIONS:
        if (sources == "*" or mode in sources) and condition(mode, inputs):
            return target
    return mode


def latched_after(latched: bool, mode: Mode, new_mode: Mode, inputs: Inputs) -> bool:
    """The stop latch after this tick's transition.

    Set when an E-stop or a device fault ends a mode (or keeps PASSIVE); cleared
    only by the remote asking for PASSIVE with the E-stop released and every
    device well (the switch's way back).
    """
    if inputs.estop or (new_mode == Mode.PASSIVE and not inputs.devices_ok and mode in ENABLED):
        return True
    if inputs.request == Mode.PASSIVE and inputs.devices_ok:
        return False
    return latched
