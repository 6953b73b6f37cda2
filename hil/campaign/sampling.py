"""What each run of a campaign is: its scenario, sample index, seed and plant overrides.

Every draw is a pure function of (campaign seed, sample index, override key),
so a sample's overrides do not depend on the order the runs finish in, on the
other keys varied, or on how many samples were asked for: a resumed or extended
campaign draws exactly what the first attempt did. Sample i carries the same
overrides and seed in every scenario of the campaign (common random numbers:
the scenarios are compared on the same plants).
"""
from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

# Named boxes of plant overrides, key -> (low, high) in the key's unit (see
# wheelleg.emulators.plant.OVERRIDES). `tolerance` is what a real robot of this
# build differs from its model by, each range from a source (a datasheet, a
# published measurement of the part, a manufacturing tolerance, or a derivation
# from them): docs/robot.md, "The tolerance box", gives each one's source.
# Left and right are drawn independently (a key per side, the common key left at
# its default). `tolerance-v1` is the box before the sources (drawn by the hands
# that tuned the controller, without the keys the plant lacked then), kept for comparison.
_HIP_ZERO_RAD = 0.02  # each hip's zero set by hand against its stop
TOLERANCE = {
    # mass and CoM: battery and cabling
    "body_mass_scale": (0.95, 1.20),
    "inertia_scale": (0.7, 1.3),
    "com_x_m": (-0.02, 0.02),
    "com_y_m": (-0.01, 0.01),
    "com_z_m": (-0.015, 0.015),
    # CyberGear hips
    "hip_armature": (0.0012, 0.014),
    "hip_damping": (0.002, 0.005),
    "hip_frictionloss_left": (0.15, 0.435),
    "hip_frictionloss_right": (0.15, 0.435),
    "hip_kt_scale_left": (0.90, 1.03),
    "hip_kt_scale_right": (0.90, 1.03),
    **{f"hip_zero_offset_{leg}_{hip}": (-_HIP_ZERO_RAD, _HIP_ZERO_RAD)
       for leg in ("left", "right") for hip in ("front", "rear")},
    "hip_torque_lag_s": (0.00016, 0.0027),
    # M3508 + C620 wheels, tyres, floor
    "wheel_damping": (0.002, 0.005),
    "wheel_frictionloss_left": (0.06, 0.16),
    "wheel_frictionloss_right": (0.06, 0.16),
    "wheel_kt_scale_left": (0.90, 1.03),
    "wheel_kt_scale_right": (0.90, 1.03),
    "wheel_torque_lag_s": (0.00016, 0.001),
    "wheel_radius_scale": (0.96, 1.01),
    "friction": (0.5, 1.0),
    # BMI088 IMU and its mount
    "imu_tilt_pitch_deg": (-1.5, 1.5),
    "imu_tilt_roll_deg": (-1.5, 1.5),
    "imu_gyro_bias_x": (-0.0175, 0.0175),
    "imu_gyro_bias_y": (-0.0175, 0.0175),
    "imu_gyro_bias_z": (-0.0175, 0.0175),
    "imu_noise_scale": (1.0, 2.0),
    # bus and drivers
    "feedback_delay_s": (0.0, 0.001),
    "command_delay_s": (0.0, 0.001),
    # a 6S LiPo from full to flat, new to worn
    "supply_voltage_v": (21.0, 25.2),
    "battery_resistance_ohm": (0.018, 0.108),
}
PRESETS: dict[str, dict[str, tuple[float, float]]] = {
    "tolerance": TOLERANCE,
    "tolerance-v1": {
        "body_mass_scale": (0.8, 1.4),
        "com_x_m": (-0.03, 0.03),
        "com_z_m": (-0.02, 0.02),
        "friction": (0.5, 1.5),
        "hip_kt_scale": (0.85, 1.15),
        "wheel_kt_scale": (0.85, 1.15),
        "imu_tilt_pitch_deg": (-3.0, 3.0),
        "imu_tilt_roll_deg": (-3.0, 3.0),
        "imu_gyro_bias": (-0.05, 0.05),
        "feedback_delay_s": (0.0, 0.002),
        "command_delay_s": (0.0, 0.002),
        "supply_voltage_v": (22.0, 26.0),
    },
}

SIGNIFICANT_DIGITS = 6  # a drawn value is rounded so the rerun command (k=v) gives the very same run


@dataclass(frozen=True)
class Job:
    """One run of a campaign: ``scenario`` at ``seed`` with plant ``overrides`` (key -> value, SI)."""

    scenario: str
    sample: int
    seed: int
    overrides: dict


def parse_range(text: str) -> tuple[str, tuple[float, float]]:
    """``KEY=LOW..HIGH`` -> (key, (low, high)); ValueError (one line) when malformed or LOW > HIGH."""
    key, sep, span = text.partition("=")
    low_text, dots, high_text = span.partition("..")
    if not sep or not dots or not key.strip():
        raise ValueError(f"--vary {text!r}: expected KEY=LOW..HIGH, e.g. com_x_m=-0.03..0.03")
    try:
        low, high = float(low_text), float(high_text)
    except ValueError:
        raise ValueError(f"--vary {text!r}: LOW and HIGH must be numbers") from None
    if not (np.isfinite(low) and np.isfinite(high)):
        raise ValueError(f"--vary {text!r}: LOW and HIGH must be finite")
    if low > high:
        raise ValueError(f"--vary {text!r}: LOW {low:g} > HIGH {high:g}")
    return key.strip(), (low, high)


def campaign_ranges(preset: str | None, varies: list[str]) -> dict[str, tuple[float, float]]:
    """The box to draw from: the preset's ranges, then each ``--vary`` (which wins on the same key)."""
    if preset is not None and preset not in PRESETS:
        raise ValueError(f"no preset {preset!r}; known: {', '.join(sorted(PRESETS))}")
    ranges = dict(PRESETS[preset]) if preset else {}
    for text in varies:
        key, span = parse_range(text)
        ranges[key] = span
    return dict(sorted(ranges.items()))


def run_seed(campaign_seed: int, sample: int) -> int:
    """The rig seed (noise, faults) of sample ``sample``: a 31-bit int, the same in every scenario."""
    return int(np.random.SeedSequence([campaign_seed, sample, 0]).generate_state(1)[0] >> 1)


def draw_overrides(campaign_seed: int, sample: int, ranges: dict[str, tuple[float, float]]) -> dict:
    """Sample ``sample``'s overrides: each key uniform in its (low, high), from its own stream."""
    drawn = {}
    for key, (low, high) in sorted(ranges.items()):
        stream = np.random.SeedSequence([campaign_seed, sample, 1, zlib.crc32(key.encode())])
        value = np.random.default_rng(stream).uniform(low, high)
        drawn[key] = float(f"{value:.{SIGNIFICANT_DIGITS}g}")
    return drawn


def plan(scenarios: list[str], samples: int, campaign_seed: int, ranges: dict) -> list[Job]:
    """Every run of the campaign, sample-major (all scenarios of sample 0 first)."""
    jobs = []
    for sample in range(samples):
        seed = run_seed(campaign_seed, sample)
        overrides = draw_overrides(campaign_seed, sample, ranges)
        jobs += [Job(name, sample, seed, overrides) for name in scenarios]
    return jobs
