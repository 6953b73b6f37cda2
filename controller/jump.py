"""The jump sequence (docs/control.md, jumps): squat, thrust, retract, flight, land.

``PHASES`` is the table: for each phase, what the chassis does in it and how
it ends (its exit condition, or its timeout, each naming the next phase).
``JumpSequencer.step`` is called once per tick in Mode.JUMP with what the
controller measured; it returns the phase's ``JumpCommand``. The off-ground
check (the support force) is not consulted in SQUAT and THRUST, where the
legs' own pushing makes Fn meaningless; FLIGHT ends on touchdown (either
leg's Fn above ``P.FN_ON``), so a thrust too weak to leave the ground just
lands at once.

JumpForward is the same table with a forward speed set point held from the
squat to the landing, so the robot carries momentum onto a step; its squat
also waits for a steady run-up (at speed, legs upright): a thrust while the
robot still leans into its acceleration throws the legs back and, in the
air, swinging them upright pitches the body nose down.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Callable

from wheelleg.controller import params as P


class Phase(enum.IntEnum):
    SQUAT = 0  # legs to the squat length, balancing on the wheels
    THRUST = 1  # open-loop push along the legs, decaying towards full stretch
    RETRACT = 2  # pull the wheels up towards the body (leg PD, damped: no slam on the stop)
    FLIGHT = 3  # legs held vertical at the landing length until touchdown
    LAND = 4  # balancing again, legs absorb from where they touched down
    DONE = 5


@dataclass(frozen=True)
class JumpView:
    """What a phase's exit (and THRUST's force) looks at this tick."""

    elapsed_s: float  # s in this phase
    leg_length: float  # m, the longer leg in THRUST, the shorter one in every other phase
    touching: bool  # either leg's Fn above P.FN_ON this tick
    steady: bool = True  # a forward jump's run-up: at its speed with the legs upright


@dataclass(frozen=True)
class JumpCommand:
    """What the chassis does this tick of the jump."""

    phase: Phase
    airborne: bool  # wheels unpowered, legs held vertical (air control)
    leg_length: float | None  # m, leg-length set point (None: the operator's)
    leg_force: float | None  # N per leg, open-loop push replacing the leg PID (None: PID)
    hip_torque_limit: float  # N m


def _thrust_force(view: JumpView) -> float:
    """Smooth decay 1 - 3s^2 + 2s^3 over the stroke (rm_controllers' Hermite)."""
    s = (view.leg_length - P.JUMP_SQUAT_LENGTH) / (P.JUMP_THRUST_END_LENGTH - P.JUMP_SQUAT_LENGTH)
    s = min(max(s, 0.0), 1.0)
    return P.JUMP_THRUST_FORCE * (1.0 - 3.0 * s * s + 2.0 * s ** 3) + P.LEG_GRAVITY_FF


@dataclass(frozen=True)
class PhaseSpec:
    airborne: bool  # in-air control (chassis ``_air_step``)
    leg_length: float | None  # m, leg-length set point; None: the operator's
    force: Callable | None  # fn(view) -> N, or None for the leg PID
    hip_torque_limit: float  # N m
    done: Callable  # fn(view) -> bool: the phase's goal reached
    then: Phase  # next phase when done
    timeout_s: float  # s in the phase before ``on_timeout``
    on_timeout: Phase


PHASES: dict = {
    Phase.SQUAT: PhaseSpec(False, P.JUMP_SQUAT_LENGTH, None, P.HIP_TORQUE_LIMIT,
                           lambda v: v.leg_length < P.JUMP_SQUAT_LENGTH + 0.01 and v.elapsed_s > P.JUMP_SQUAT_MIN_S and v.steady,
                           Phase.THRUST, P.JUMP_SQUAT_TIMEOUT, Phase.THRUST),
    Phase.THRUST: PhaseSpec(False, None, _thrust_force, P.JUMP_HIP_TORQUE_LIMIT,
                            lambda v: v.leg_length > P.JUMP_THRUST_END_LENGTH,
                            Phase.RETRACT, P.JUMP_THRUST_TIMEOUT, Phase.RETRACT),
    Phase.RETRACT: PhaseSpec(True, P.JUMP_RETRACT_TARGET, None, P.JUMP_HIP_TORQUE_LIMIT,
                             lambda v: v.leg_length < P.JUMP_RETRACT_LENGTH,
                             Phase.FLIGHT, P.JUMP_RETRACT_TIMEOUT, Phase.FLIGHT),
    Phase.FLIGHT: PhaseSpec(True, P.JUMP_LAND_LENGTH, None, P.HIP_TORQUE_LIMIT,
                            lambda v: v.touching and v.elapsed_s > P.JUMP_FLIGHT_MIN_S,
                            Phase.LAND, P.JUMP_FLIGHT_TIMEOUT, Phase.LAND),
    Phase.LAND: PhaseSpec(False, None, None, P.HIP_TORQUE_LIMIT,
                          lambda v: False, Phase.DONE, P.JUMP_LAND_TIME, Phase.DONE),
}


def table_next_phase(phases: dict, phase, view):
    """The phase after this tick in a phase table (this ``PHASES``, recovery's): its
    ``done`` goal reached, its timeout, or the same. A phase the table does not
    list (DONE) stays. ``view`` has ``elapsed_s`` and what the ``done`` tests read."""
    spec = phases.get(phase)
    if spec is None:
        return phase
    if spec.done(view):
        return spec.then
    if view.elapsed_s >= spec.timeout_s:
        return spec.on_timeout
    return phase


def next_phase(phase: Phase, view: JumpView) -> Phase:
    """The jump's phase after this tick (``table_next_phase`` on ``PHASES``)."""
    return table_next_phase(PHASES, phase, view)


class JumpSequencer:
    """Runs the table, one ``step`` per tick; ``phase`` is DONE when landed."""

    def __init__(self, dt_s: float):
        self.dt = dt_s
        self.phase = Phase.DONE
        self.elapsed_s = 0.0
        self.forward = False
        self.entered: Phase | None = None  # the phase entered this tick (None: no change)

    def start(self, forward: bool = False) -> None:
        self.phase, self.elapsed_s, self.forward, self.entered = Phase.SQUAT, 0.0, forward, Phase.SQUAT

    @property
    def done(self) -> bool:
        return self.phase == Phase.DONE

    def step(self, lengths: tuple[float, float], touching: bool, steady: bool = True) -> JumpCommand:
        """Advance with both legs' lengths (m), touchdown and (forward jumps) whether the
        run-up is steady; the command for this tick."""
        pick = max if self.phase == Phase.THRUST else min
        view = JumpView(self.elapsed_s, pick(lengths), touching, steady)
        new = next_phase(self.phase, view)
        self.entered = new if new != self.phase else None
        if self.entered is not None:
            self.phase, self.elapsed_s = new, 0.0
        self.elapsed_s += self.dt
        if self.phase == Phase.DONE:
            return JumpCommand(Phase.DONE, False, None, None, P.HIP_TORQUE_LIMIT)
        spec = PHASES[self.phase]
        force = spec.force(JumpView(self.elapsed_s, pick(lengths), touching)) if spec.force else None
        return JumpCommand(self.phase, spec.airborne, spec.leg_length, force, spec.hip_torque_limit)
