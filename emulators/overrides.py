"""Per-run changes to the plant's truth: the one registry of what may be changed, and how far.

A HIL rig that only ever runs the robot the controller was tuned on cannot
say FAIL where the real robot would fall. Each override moves one true value
of the plant (the MJCF, a device, a sensor, the bus timing) away from the
robot description (emulators/robot/description.py) while the controller keeps
its belief. ``OVERRIDES`` is the single registry: the CLI's help, the
validation (``check_override``) and the campaigns read it.

Every key is a float in SI units (or a scale factor, 1 = nominal); the
default leaves the plant exactly as described.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

from wheelleg.emulators.robot import description as D


@dataclass(frozen=True)
class OverrideSpec:
    """One override: unit ('' for a scale), default (the described robot), allowed range (inclusive)."""

    unit: str
    default: float
    low: float
    high: float
    description: str

    def range_text(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        return f"{self.low:g}..{self.high:g}{unit}"


def _spec(unit: str, default: float, low: float, high: float, description: str) -> OverrideSpec:
    return OverrideSpec(unit, float(default), float(low), float(high), description)


_BIAS = (-0.5, 0.5)  # rad/s: far beyond any gyro's bias after power-on calibration
OVERRIDES: dict[str, OverrideSpec] = {
    "body_mass_scale": _spec("", 1.0, 0.2, 5.0, "body mass (and its inertia with it) times this"),
    "com_x_m": _spec("m", 0.0, -0.1, 0.1, "body CoM moved forward (+) or back along body x"),
    "com_z_m": _spec("m", 0.0, -0.1, 0.1, "body CoM moved up (+) or down along body z"),
    "inertia_scale": _spec("", 1.0, 0.2, 5.0, "body rotational inertia times this (mass unchanged)"),
    "friction": _spec("", 1.0, 0.05, 3.0, "sliding friction of tyre on floor (and on terrain of the floor's friction)"),
    "wheel_radius_scale": _spec("", 1.0, 0.8, 1.25, "tyre radius times this (the controller still believes "
                                f"{D.WHEEL_RADIUS_M} m)"),
    "hip_kt_scale": _spec("", 1.0, 0.5, 1.5, "CyberGear true torque per commanded torque (firmware Kt wrong)"),
    "wheel_kt_scale": _spec("", 1.0, 0.5, 1.5, "M3508 true torque constant over the datasheet's "
                            f"{D.M3508_TORQUE_CONSTANT_NM_PER_A} N m/A"),
    "hip_damping": _spec("N m s/rad", 0.0, 0.0, 2.0, "viscous damping in each hip joint"),
    "hip_frictionloss": _spec("N m", 0.0, 0.0, 3.0, "dry friction in each hip joint"),
    "imu_tilt_pitch_deg": _spec("deg", 0.0, -15.0, 15.0, "IMU mounted pitched (nose down +) on the body"),
    "imu_tilt_roll_deg": _spec("deg", 0.0, -15.0, 15.0, "IMU mounted rolled (right side down +) on the body"),
    "imu_gyro_bias": _spec("rad/s", 0.0, *_BIAS, "gyro bias on all three axes (added to the per-axis ones)"),
    "imu_gyro_bias_x": _spec("rad/s", 0.0, *_BIAS, "gyro bias on body x (roll rate)"),
    "imu_gyro_bias_y": _spec("rad/s", 0.0, *_BIAS, "gyro bias on body y (pitch rate)"),
    "imu_gyro_bias_z": _spec("rad/s", 0.0, *_BIAS, "gyro bias on body z (yaw rate)"),
    "imu_noise_scale": _spec("", 1.0, 0.0, 50.0, "IMU white noise (gyro, accel, attitude) times this"),
    "feedback_delay_s": _spec("s", 0.0, 0.0, 0.05, "extra latency of every device frame to the controller "
                              "(taken at the plant's next service instant, every physics step)"),
    "command_delay_s": _spec("s", 0.0, 0.0, 0.05, "extra latency of every controller frame to the devices "
                             "(taken at the plant's next service instant, every physics step)"),
    "supply_voltage_v": _spec("V", D.SUPPLY_NOMINAL_V, *D.SUPPLY_RANGE_V, "battery voltage: the motors' "
                              "no-load speeds (back-EMF limits) scale with it; the CyberGears report it"),
    # --- the imperfections of geared actuators and of a real build (docs/robot.md, the tolerance box) ---
    "hip_armature": _spec("kg m^2", D.HIP_ARMATURE_KG_M2, 0.0, 0.05, "reflected inertia of rotor and gearbox "
                          "at each hip joint (MuJoCo joint armature)"),
    "wheel_damping": _spec("N m s/rad", 0.0, 0.0, 0.5, "viscous damping of each wheel drive (M3508 gearbox)"),
    "wheel_frictionloss": _spec("N m", 0.0, 0.0, 1.0, "dry friction of each wheel drive (M3508 gearbox)"),
    **{f"hip_zero_offset_{m.name.removesuffix('_hip')}": _spec(
        "rad", 0.0, -0.2, 0.2, f"{m.name}'s encoder zero set this far off the mechanical stop: the "
        "CyberGear reports the shaft angle minus it") for m in D.HIP_MOTORS},
    **{key: spec for side in ("left", "right") for key, spec in (
        (f"hip_kt_scale_{side}", _spec("", 1.0, 0.5, 1.5, f"the {side} hips' true torque per commanded "
                                       "torque, times hip_kt_scale")),
        (f"wheel_kt_scale_{side}", _spec("", 1.0, 0.5, 1.5, f"the {side} M3508's true torque constant over "
                                         "the datasheet's, times wheel_kt_scale")),
        (f"hip_frictionloss_{side}", _spec("N m", 0.0, 0.0, 3.0, f"dry friction in each {side} hip joint, "
                                           "added to hip_frictionloss")),
        (f"wheel_frictionloss_{side}", _spec("N m", 0.0, 0.0, 1.0, f"dry friction of the {side} wheel drive, "
                                             "added to wheel_frictionloss")))},
    "com_y_m": _spec("m", 0.0, -0.1, 0.1, "body CoM moved left (+) or right along body y"),
    "battery_resistance_ohm": _spec("ohm", 0.0, 0.0, 0.5, "battery and cabling resistance: the motors' supply "
                                    "sags by it times the current they draw (the CyberGears report it)"),
    "hip_torque_lag_s": _spec("s", 0.0, 0.0, 0.02, "first-order lag (time constant) of each hip's torque "
                              "behind its command (the motor's current loop)"),
    "wheel_torque_lag_s": _spec("s", 0.0, 0.0, 0.02, "first-order lag (time constant) of each wheel's torque "
                                "behind its command (the C620's current loop)"),
}


def check_override(key: str, value: str | float) -> float:
    """``value`` of override ``key`` as a float; ValueError (one line) for an unknown key or an impossible value."""
    spec = OVERRIDES.get(key)
    if spec is None:
        raise ValueError(f"unknown plant override {key!r}; known: {', '.join(OVERRIDES)}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"plant override {key}: {value!r} is not a number") from None
    if isinstance(value, bool) or not math.isfinite(number) or not spec.low <= number <= spec.high:
        raise ValueError(f"plant override {key}={value!r} is impossible: allowed {spec.range_text()}")
    return number


def check_overrides(mapping: Mapping[str, str | float]) -> dict[str, float]:
    """Every item of ``mapping`` checked (``check_override``), as floats, in registry order."""
    checked = {key: check_override(key, value) for key, value in mapping.items()}
    return {key: checked[key] for key in OVERRIDES if key in checked}


def parse_assignment(text: str) -> tuple[str, float]:
    """'KEY=VALUE' (as given to ``--plant``) -> (key, value); ValueError (one line) when malformed or invalid."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip() or not value.strip():
        raise ValueError(f"plant override {text!r}: expected KEY=VALUE, e.g. com_x_m=0.02")
    return key.strip(), check_override(key.strip(), value.strip())


def help_text() -> str:
    """One line per override: key, unit, default, range, description (for the CLI's help)."""
    return "\n".join(f"  {key} ({spec.unit or 'scale'}): default {spec.default:g}, allowed "
                     f"{spec.low:g}..{spec.high:g}; {spec.description}" for key, spec in OVERRIDES.items())
