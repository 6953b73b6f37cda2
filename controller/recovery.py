"""Recovery stand from lying (the MIT Cheetah's RECOVERY_STAND, for a wheel-legged body).

When STAND_UP starts with the body past the fall limits (lying on its nose
after a fall, legs limp and swung back), the ordinary stand-up cannot work:
the LQR's model is upright, its wheel torque saturates on the leg angle and
spins the unloaded wheels up. Two phases first, a table like controller/jump.py:

- TUCK: wheels unpowered, no torque on the leg angle (the legs swing free), the
  legs pulled short: the hips come down towards the wheels, which roll in
  under the body. (Holding the legs vertical instead, as in the air, swings
  the body over its nose onto its face: tried in the rig.)
- TILT_UP: the LQR balances again around a body pitch set point that starts
  at the measured pitch and ramps to the operator's at ``RECOVERY_PITCH_RATE``,
  never held behind a body that rises faster (``next_pitch_ref``), the position
  reference following the robot (the rise rolls it forward);
- DONE: the ordinary stand-up takes over (legs to the set length, stood-up check).
"""
from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Callable

from wheelleg.controller import params as P
from wheelleg.controller.jump import table_next_phase


class Phase(enum.IntEnum):
    TUCK = 0
    TILT_UP = 1
    DONE = 2


@dataclass(frozen=True)
class RecoveryView:
    elapsed_s: float  # s in this phase
    max_length: float  # m, the longer leg
    pitch_ref_settled: bool  # the ramped pitch set point has reached the operator's


@dataclass(frozen=True)
class PhaseSpec:
    airborne: bool  # in-air control: wheels unpowered, leg-angle torque off (legs swing free)
    leg_length: float | None  # m, None: the operator's
    done: Callable  # fn(RecoveryView) -> bool: the phase's goal reached
    then: Phase  # next phase when done
    timeout_s: float  # s in the phase before ``on_timeout``
    on_timeout: Phase


PHASES: dict = {
    Phase.TUCK: PhaseSpec(True, P.RECOVERY_TUCK_LENGTH,
                          lambda v: v.elapsed_s > P.RECOVERY_TUCK_MIN_S and v.max_length < P.RECOVERY_TUCK_LENGTH + 0.01,
                          Phase.TILT_UP, P.RECOVERY_TUCK_TIMEOUT, Phase.TILT_UP),
    Phase.TILT_UP: PhaseSpec(False, P.RECOVERY_TUCK_LENGTH, lambda v: v.pitch_ref_settled,
                             Phase.DONE, P.RECOVERY_TILT_TIMEOUT, Phase.DONE),
}


def next_phase(phase: Phase, view: RecoveryView) -> Phase:
    """The recovery's phase after this tick (jump.table_next_phase on ``PHASES``)."""
    return table_next_phase(PHASES, phase, view)


@dataclass(frozen=True)
class RecoveryCommand:
    phase: Phase
    airborne: bool
    leg_length: float | None
    pitch: float | None  # rad, body pitch set point (nose down +); None: the operator's


class RecoverySequencer:
    """One ``step`` per STAND_UP tick; ``active`` while the robot is being righted."""

    def __init__(self, dt_s: float):
        self.dt = dt_s
        self.phase = Phase.DONE
        self.elapsed_s = 0.0
        self.pitch_ref = 0.0
        self.entered: Phase | None = None

    @property
    def active(self) -> bool:
        return self.phase != Phase.DONE

    def start(self) -> None:
        self.phase, self.elapsed_s, self.entered = Phase.TUCK, 0.0, Phase.TUCK

    def stop(self) -> None:
        self.phase, self.entered = Phase.DONE, None

    def step(self, lengths, pitch: float, target_pitch: float) -> RecoveryCommand:
        """Advance with both legs' lengths (m), the body pitch and the operator's pitch (rad)."""
        settled = abs(self.pitch_ref - target_pitch) < 1e-6
        view = RecoveryView(self.elapsed_s, max(lengths), settled)
        new = next_phase(self.phase, view)
        self.entered = new if new != self.phase else None
        if self.entered is not None:
            self.phase, self.elapsed_s = new, 0.0
            if new == Phase.TILT_UP:
                self.pitch_ref = pitch  # balance first where the body is
        self.elapsed_s += self.dt
        if self.phase == Phase.DONE:
            return RecoveryCommand(Phase.DONE, False, None, None)
        if self.phase == Phase.TILT_UP:
            self.pitch_ref = next_pitch_ref(self.pitch_ref, pitch, target_pitch, P.RECOVERY_PITCH_RATE * self.dt)
        spec = PHASES[self.phase]
        return RecoveryCommand(self.phase, spec.airborne, spec.leg_length,
                               self.pitch_ref if self.phase == Phase.TILT_UP else None)


def next_pitch_ref(ref: float, measured: float, target: float, max_step: float) -> float:
    """The rise's pitch set point (rad, nose down +) one tick on: ``max_step`` (rad) nearer
    ``target``, starting from the ``measured`` pitch when the body is already nearer the
    target than the set point (it only ever moves towards the target).

    Held behind a body that rises faster than the ramp, the LQR pushed the body back
    down and its wheels ran away under it instead: `fall` rolled 2.4 m in the 2.7 s of
    its recovery; from the measured pitch, 1.1 m in 1.1 s.
    """
    if min(ref, target) <= measured <= max(ref, target):
        ref = measured
    return ref + max(-max_step, min(max_step, target - ref))
