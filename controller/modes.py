"""Operating modes, after the MIT Cheetah's mode machine (ControlFSM; docs/control.md).

E-stop from the remote's switch wins from any mode; the motors are enabled
only in STAND_UP, BALANCE, MOVE and JUMP. The transitions are an explicit table
of (from, condition, to), checked in order; the first that holds is taken.
The mode numbers are those of rig.dbc's Heartbeat.Mode.
"""
from __future__ import annotations

import enum
from typing import NamedTuple


class Mode(enum.IntEnum):
    ESTOP = 0  # torque off on the remote's E-stop switch
    IDLE = 1  # powered up, motors off, waiting for the remote
    STAND_UP = 2  # motors on, legs rising to the set height while balancing
    BALANCE = 3  # standing in place
    MOVE = 4  # following speed and yaw-rate commands
    JUMP = 5  # squat, thrust, retract, land
    AIRBORNE = 6  # wheels off the ground (after a drop or a push)
    FALLEN = 7  # fell past what the controller can save: torque off
    DISABLED = 8  # a device the balance needs is offline or faulted: torque off


class Switch(enum.IntEnum):
    """The remote's mode switch (rig.dbc Operator.Mode)."""

    ESTOP = 0
    STAND = 1
    MOVE = 2


ENABLED = frozenset({Mode.STAND_UP, Mode.BALANCE, Mode.MOVE, Mode.JUMP, Mode.AIRBORNE})


class Inputs(NamedTuple):
    """What the mode machine looks at each tick (a NamedTuple: immutable, made every tick
    ~5x faster than a frozen dataclass, which sets each field through object.__setattr__)."""

    switch: Switch
    devices_ok: bool  # every device the balance needs is online and fault-free
    reenable: bool  # the remote's re-enable button went down this tick
    jump: bool  # the remote's jump button went down this tick
    fallen: bool  # pitch / leg angle / roll past the limits, or body on the ground
    stood_up: bool  # legs at their set length and the body upright
    off_ground: bool  # both wheels without support force (debounced)
    jump_done: bool  # the jump sequence finished (landed)
    can_rise: bool  # the body is upright enough to try standing up


# the members the conditions compare with every tick, as module names: in CPython 3.11 an
# Enum member's lookup on its class costs ~10 times a global's
_ESTOP, _STAND, _MOVE = Switch.ESTOP, Switch.STAND, Switch.MOVE
_MODE_ESTOP = Mode.ESTOP

# (from modes, condition, to). "*" means any mode.
TRANSITIONS: tuple = (
    ("*", lambda m, i: i.switch == _ESTOP and m != _MODE_ESTOP, Mode.ESTOP),
    ("*", lambda m, i: m in ENABLED and not i.devices_ok, Mode.DISABLED),
    # in JUMP and AIRBORNE the controller judges "fallen" with wider limits (node.py)
    ("*", lambda m, i: m in ENABLED and i.fallen, Mode.FALLEN),
    ((Mode.ESTOP, Mode.IDLE), lambda m, i: i.switch != _ESTOP and i.devices_ok and i.can_rise,
     Mode.STAND_UP),
    ((Mode.DISABLED, Mode.FALLEN), lambda m, i: i.reenable and i.devices_ok and i.switch != _ESTOP,
     Mode.STAND_UP),
    ((Mode.STAND_UP,), lambda m, i: i.stood_up, Mode.BALANCE),
    ((Mode.BALANCE, Mode.MOVE), lambda m, i: i.jump, Mode.JUMP),
    ((Mode.BALANCE, Mode.MOVE), lambda m, i: i.off_ground, Mode.AIRBORNE),
    ((Mode.BALANCE,), lambda m, i: i.switch == _MOVE, Mode.MOVE),
    ((Mode.MOVE,), lambda m, i: i.switch == _STAND, Mode.BALANCE),
    ((Mode.JUMP,), lambda m, i: i.jump_done, Mode.BALANCE),
    ((Mode.AIRBORNE,), lambda m, i: not i.off_ground, Mode.BALANCE),
)


# mode -> its (condition, to) pairs, in the table's order (picked once, not every tick)
_FROM: dict = {mode: tuple((condition, target) for sources, condition, target in TRANSITIONS
                           if sources == "*" or mode in sources) for mode in Mode}


def next_mode(mode: Mode, inputs: Inputs) -> Mode:
    """The mode after this tick: the first transition from ``mode`` that holds."""
    for condition, target in _FROM[mode]:
        if condition(mode, inputs):
            return target
    return mode
