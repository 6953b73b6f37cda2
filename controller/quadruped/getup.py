"""Getting up: the stand-up and the recovery stand, as joint-space trajectories in a phase table.

Stand-up (from lying folded, body upright): GATHER (legs to the crouch, feet
under the hips) then RISE (crouch to the stand), minimum-jerk in joint space,
with the weight's feed-forward growing over the rise. Legs already under the
hips of a body above the crouch (it was standing) skip the gather.

Recovery (the MIT Cheetah's recovery stand): a body not upright (on a side,
on its back) first rolls over: ROLL (the legs of the side it lies on press the
ground behind its back, levering it up), FLIP (they fold under while the
other side's legs swing over the back: it rolls onto its belly), SETTLE; then
FOLD the legs and look again: upright, it goes on as the stand-up; still not,
it rolls again, at most ``params.ROLL_ATTEMPTS`` times (then GIVEN_UP: lie
folded, held by the joint PD, until the remote asks again).

Each phase runs for its time; at its end ``NEXT`` (a table of functions of
whether the body is upright and of the roll-overs made) names the next one.
"""
from __future__ import annotations

import enum

import numpy as np

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped import legs, stance
from wheelleg.controller.quadruped.legs import JointCommands
from wheelleg.controller.quadruped.sensed import Sensed, height_over_feet


class Phase(enum.IntEnum):
    IDLE = 0
    FOLD = 1
    ROLL = 2
    FLIP = 3
    SETTLE = 4
    GATHER = 5
    RISE = 6
    DONE = 7
    GIVEN_UP = 8


DURATION_S = {Phase.FOLD: P.FOLD_S, Phase.ROLL: P.ROLL_S, Phase.FLIP: P.FLIP_S, Phase.SETTLE: P.SETTLE_S,
              Phase.GATHER: P.GATHER_S, Phase.RISE: P.RISE_S}

# phase that ended -> next phase, given (upright, attempts made so far)
NEXT = {
    Phase.FOLD: lambda upright, attempts: (Phase.GATHER if upright else
                                           Phase.ROLL if attempts < P.ROLL_ATTEMPTS else Phase.GIVEN_UP),
    Phase.ROLL: lambda upright, attempts: Phase.FLIP,
    Phase.FLIP: lambda upright, attempts: Phase.SETTLE,
    Phase.SETTLE: lambda upright, attempts: Phase.FOLD,
    Phase.GATHER: lambda upright, attempts: Phase.RISE,
    Phase.RISE: lambda upright, attempts: Phase.DONE,
}


def min_jerk(s: float) -> tuple[float, float]:
    """(position, rate) fractions of a minimum-jerk move at progress ``s`` in [0, 1] (rate per unit of s)."""
    s = min(max(s, 0.0), 1.0)
    return s ** 3 * (10.0 - 15.0 * s + 6.0 * s * s), 30.0 * s * s * (1.0 - s) ** 2


def stand_pose(height_m: float) -> np.ndarray:
    """Joint angles (rad, (4, 3)) of a level body at ``height_m`` over the nominal footprint."""
    feet = stance.footprint()
    feet[:, 2] -= height_m
    return legs.joints_for_feet(feet)


def fold_pose() -> np.ndarray:
    """Joint angles (rad, (4, 3)) of the folded legs."""
    return np.tile(np.array(P.FOLD_POSE, dtype=float), (4, 1))


def roll_pose(roll_rad: float, flip: bool) -> np.ndarray:
    """Joint angles (rad, (4, 3)) of the roll-over's ROLL (``flip`` False) or FLIP pose while lying
    with body roll ``roll_rad`` (> 0: on the right side, the right legs are the lower ones).

    The poses are given for the left side down; a leg's abduction is mirrored with its side.
    """
    ground_side = -1.0 if roll_rad > 0 else 1.0  # +1 the left side is down
    lower, upper = (P.FLIP_LOWER, P.FLIP_UPPER) if flip else (P.ROLL_LOWER, P.ROLL_UPPER)
    q = np.array([lower if C.SIDE[leg] == ground_side else upper for leg in range(4)], dtype=float)
    q[:, 0] *= np.array(C.SIDE)
    return np.clip(q, legs.LOWER, legs.UPPER)


class GetUp:
    """The phase sequencer: ``start_stand_up`` or ``start_recovery``, then ``step`` every period."""

    def __init__(self, period_s: float = P.CONTROL_PERIOD):
        self.period_s = period_s
        self.phase = Phase.IDLE
        self.elapsed_s = 0.0
        self.attempts = 0
        self.roll_rad = 0.0  # the body's roll when the roll-over began: which side is down
        self.height_m = P.HEIGHT_NOMINAL
        self.q_from = fold_pose()
        self.q_to = fold_pose()

    @property
    def done(self) -> bool:
        return self.phase == Phase.DONE

    def stop(self) -> None:
        """Back to IDLE (the motors went passive): not done, nothing under way."""
        self.phase, self.elapsed_s = Phase.IDLE, 0.0

    def start_stand_up(self, q: np.ndarray, height_m: float) -> None:
        """From lying folded: gather, then rise. Legs already under a body above the crouch rise at once."""
        self.height_m, self.attempts = height_m, 0
        feet = legs.feet_in_body(q)
        above_crouch = height_over_feet(feet, np.ones(4, dtype=bool)) > P.CROUCH_HEIGHT + 0.01
        under_hips = np.all(np.abs(feet[:, :2] - stance.footprint()[:, :2]) < P.UNDER_HIP_TOLERANCE)
        self._enter(Phase.RISE if above_crouch and under_hips else Phase.GATHER, q, None)

    def start_recovery(self, sensed: Sensed, height_m: float) -> None:
        """Roll over first when the body is not upright, else fold; then as the stand-up."""
        self.height_m, self.attempts = height_m, 0
        self._enter(Phase.FOLD if is_upright(sensed.rpy) else Phase.ROLL, sensed.q, sensed)

    def _enter(self, phase: Phase, q_from: np.ndarray, sensed: Sensed | None) -> None:
        self.phase, self.elapsed_s = phase, 0.0
        self.q_from = np.array(q_from, dtype=float)
        if phase == Phase.FOLD or phase == Phase.GIVEN_UP:
            self.q_to = fold_pose()
        elif phase in (Phase.ROLL, Phase.FLIP):
            self.attempts += phase == Phase.ROLL
            self.roll_rad = float(sensed.rpy[0]) if phase == Phase.ROLL else self.roll_rad
            self.q_to = roll_pose(self.roll_rad, flip=phase == Phase.FLIP)
        elif phase == Phase.GATHER:
            self.q_to = stand_pose(P.CROUCH_HEIGHT)
        elif phase == Phase.RISE:
            self.q_to = stand_pose(self.height_m)
        else:  # SETTLE, DONE: hold where the last move ended
            self.q_to = self.q_from.copy()

    def step(self, sensed: Sensed) -> JointCommands:
        """This period's joint commands; moves to the next phase when this one's time is up."""
        duration = DURATION_S.get(self.phase)
        if duration is not None and self.elapsed_s >= duration - 1e-9:
            upright = is_upright(sensed.rpy)
            self._enter(NEXT[self.phase](upright, self.attempts), self.q_to, sensed)
            duration = DURATION_S.get(self.phase)
        self.elapsed_s += self.period_s
        if duration is None:
            position, rate = 1.0, 0.0
        else:
            position, rate = min_jerk(self.elapsed_s / duration)
            rate /= duration
        q = self.q_from + position * (self.q_to - self.q_from)
        commands = JointCommands.hold(q, P.GETUP_KP, P.GETUP_KD, self._weight_torques(sensed, position))
        commands.qd = rate * (self.q_to - self.q_from)
        return commands

    def _weight_torques(self, sensed: Sensed, position: float) -> np.ndarray:
        """Feed-forward of the body's weight on four feet: growing over the rise, held once standing."""
        share = {Phase.RISE: position, Phase.DONE: 1.0}.get(self.phase, 0.0)
        if share == 0.0:
            return np.zeros((4, 3))
        wrench = np.array([0.0, 0.0, share * C.MASS * C.GRAVITY, 0.0, 0.0, 0.0])
        return stance.stance_torques(sensed.q, sensed.feet_level(), sensed.level_rotation, wrench,
                                     np.ones(4, dtype=bool), P.DISTRIBUTION_REGULARISATION, P.FRICTION)


def is_upright(rpy) -> bool:
    """Roll and pitch (rad) both under ``params.UPRIGHT_LIMIT``: the body can stand up as it lies."""
    return abs(rpy[0]) < P.UPRIGHT_LIMIT and abs(rpy[1]) < P.UPRIGHT_LIMIT


def has_fallen(rpy) -> bool:
    """Roll or pitch (rad) past ``params.FALL_LIMIT``."""
    return abs(rpy[0]) > P.FALL_LIMIT or abs(rpy[1]) > P.FALL_LIMIT
