"""What stands between a motor's command and its shaft on a real robot: current-loop lag, battery sag.

Two plant overrides (emulators/overrides.py) that the devices alone do not
model, applied by the plant once per physics step:

* ``TorqueLag``: each motor's torque follows its command with a first-order
  lag (the current loop of the motor's driver), time constant per motor.
* ``sagged_voltage``: the supply the motors see is the battery's open-circuit
  voltage minus its internal (and cabling) resistance times the current they
  draw together, found from the power they draw.

Both are pure arithmetic on floats (SI units); neither touches a frame.
"""
from __future__ import annotations

import math
from typing import Sequence


class TorqueLag:
    """First-order lag of each motor's torque (N m) behind its command, stepped once per physics step.

    ``time_constants_s`` has one entry per motor (0: no lag, the command passes
    through untouched). Over a step of ``dt_s`` the torque moves the fraction
    1 - exp(-dt/T) of the way to the command (the exact response to a command held
    over the step), and the physics holds that torque over the step. Starts at 0 N m.
    """

    def __init__(self, time_constants_s: Sequence[float], dt_s: float):
        if not dt_s > 0.0 or any(not (t >= 0.0 and math.isfinite(t)) for t in time_constants_s):
            raise ValueError(f"need dt_s > 0 and time constants >= 0 s, got {dt_s!r}, {list(time_constants_s)!r}")
        self._fractions = tuple(None if t == 0.0 else 1.0 - math.exp(-dt_s / t) for t in time_constants_s)
        self.torques_nm = [0.0] * len(self._fractions)

    def __call__(self, commands_nm: Sequence[float]) -> list[float]:
        """The torques (N m) applied over the coming step, given the commands now (same order)."""
        out = self.torques_nm
        for i, (fraction, command) in enumerate(zip(self._fractions, commands_nm)):
            out[i] = command if fraction is None else out[i] + fraction * (command - out[i])
        return list(out)


def sagged_voltage(open_circuit_v: float, resistance_ohm: float, power_w: float) -> float:
    """V at the motors when they draw ``power_w`` (W, negative when braking feeds back) through
    ``resistance_ohm`` from a source of ``open_circuit_v``.

    Solves V = E - R P / V for its upper root, V = (E + sqrt(E^2 - 4 R P)) / 2; a draw
    beyond what the source can give (E^2 < 4 R P) gets E / 2, its maximum-power point.
    """
    discriminant = open_circuit_v * open_circuit_v - 4.0 * resistance_ohm * power_w
    if discriminant <= 0.0:
        return open_circuit_v / 2.0
    return (open_circuit_v + math.sqrt(discriminant)) / 2.0
