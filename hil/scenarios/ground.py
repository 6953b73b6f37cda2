"""Slopes, bumps, steps and fast turns.

Each scenario comes from a factory with its size (slope deg, bump height m,
step height m, speed m/s); the default instance is registered. ``sprint`` (a
straight run at a speed) is the top-speed figure of ``python -m tools.limits``.
"""
from __future__ import annotations

import math

import numpy as np

from wheelleg.controller import constants as C
from wheelleg.controller import params as P
from wheelleg.emulators.physics import TerrainFeature
from wheelleg.hil.run.scenario import Check, RunData, Scenario
from wheelleg.hil.scenarios.basic import forward_position, speed_tracks
from wheelleg.hil.scenarios.collisions import falls_safely, fall_time, recovers
from wheelleg.hil.scenarios.common import DEG, never_tips, no_deadline_miss, pitch_below, remote, stand

LEVEL = 3 * DEG  # rad, "held level": |roll| below this once levelled


def on_uneven_ground(x_m: float = 0.0, leg_length: float = 0.17):
    """Start standing with the leg over the lower ground lengthened until both wheels touch."""
    return lambda physics: physics.reset_standing(leg_length_m=leg_length, x_m=x_m, fit_legs_to_ground=True)


# -- checks ---------------------------------------------------------------------
def roll_below(limit_rad: float, t0: float, t1: float = np.inf) -> Check:
    def fn(run: RunData):
        worst = float(np.max(np.abs(run.window("roll", t0, t1))))
        return worst < limit_rad, f"max |roll| {worst / DEG:.2f} deg over {t0:g}-{min(t1, run.state['t'][-1]):.3g} s (limit {limit_rad / DEG:g})"

    return Check(f"|roll| < {limit_rad / DEG:g} deg over {t0:g}-{t1:g} s", fn)


LOAD_MEAN_S = 0.01  # s: a wheel's load is judged as its mean over this (a tip onto one wheel lasts tens of ms)


def both_wheels_down(t0: float, t1: float, min_n: float = 1.0) -> Check:
    """Neither wheel lifts over t0..t1 (its normal force, as a ``LOAD_MEAN_S`` running mean, >= min_n
    N): it did not tip onto one wheel. The mean, because MuJoCo's contact can read 0 N for one
    recorded sample with the wheel still pressed into the floor (clearance -0.01 mm; seen with
    heavy hip armature mid-turn, the 10 ms mean there 16-19 N): that is the solver, not a lift."""

    def fn(run: RunData):
        t = run.state["t"]
        samples = max(1, int(round(LOAD_MEAN_S / float(np.median(np.diff(t)))))) if len(t) > 1 else 1
        lows = []
        for leg in ("left", "right"):
            force = run.window(f"{leg}_normal_force", t0, t1)
            mean = np.convolve(force, np.ones(samples) / samples, mode="valid") if len(force) >= samples else force
            lows.append((float(np.min(mean)), float(np.min(force))))
        low, least = min(m for m, _ in lows), min(x for _, x in lows)
        return low >= min_n, (f"least wheel normal force {low:.1f} N over {t0:g}-{t1:g} s as a "
                              f"{LOAD_MEAN_S * 1000:g} ms mean (at least {min_n:g}; least sample {least:.1f} N)")

    return Check(f"both wheels on the ground over {t0:g}-{t1:g} s", fn)


def travels_past(x_m: float) -> Check:
    def fn(run: RunData):
        far = float(np.max(forward_position(run)))
        return far > x_m, f"travelled {far:.2f} m forward (past {x_m:g})"

    return Check(f"travels past {x_m:g} m", fn)


def never_fallen() -> Check:
    def fn(run: RunData):
        t_fall = fall_time(run)
        return t_fall is None, "never FALLEN" if t_fall is None else f"FALLEN at {t_fall:.2f} s"

    return Check("stays up (never FALLEN)", fn)


def leans_into_turn(yaw_rate: float, t0: float, t1: float, min_rad: float) -> Check:
    """Mean roll over t0..t1 leans towards the turn's centre by at least ``min_rad``.

    Turning left (yaw_rate > 0) the robot leans left: left side down, roll < 0.
    """

    def fn(run: RunData):
        lean = -math.copysign(1.0, yaw_rate) * float(np.mean(run.window("roll", t0, t1)))
        return lean >= min_rad, f"mean lean into the turn {lean / DEG:.1f} deg over {t0:g}-{t1:g} s (at least {min_rad / DEG:.1f})"

    return Check(f"leans into the turn by >= {min_rad / DEG:.1f} deg", fn)


# -- slope: stand across a side slope -----------------------------------------------------------
def slope_scenario(angle_deg: float = 15.0) -> Scenario:
    """Stand across a side slope of ``angle_deg`` (left side up) and level the body."""
    if not 0 < angle_deg < 60:
        raise ValueError(f"angle_deg must be in (0, 60), got {angle_deg}")
    # the uphill leg shortened by half the tilt across the track (not below the
    # controller's shortest), the downhill one fitted to the ground
    across = 2 * C.HALF_TRACK * math.tan(math.radians(angle_deg))
    uphill = max(P.LEG_LENGTH_MIN, 0.17 - across / 2)
    return Scenario(
        "slope", f"stand across a {angle_deg:g} deg side slope, body held level", 5.0,
        on_uneven_ground(leg_length=uphill),
        terrain=(TerrainFeature.slope(math.radians(angle_deg)),), timeline=(stand(),),
        checks=(never_fallen(), roll_below(LEVEL, 3.0), pitch_below(3 * DEG, 3.0), both_wheels_down(1.0, 5.0),
                no_deadline_miss()))


# -- bump: one wheel up on a bump ---------------------------------------------------------------
def bump_scenario(height_m: float = 0.04) -> Scenario:
    """Stand with the left wheel on a bump ``height_m`` high, level the body; then
    drive off it forward (the wheel drops) and stop, level again."""
    if height_m <= 0:
        raise ValueError(f"height_m must be > 0, got {height_m}")
    bump = TerrainFeature.bump(x_m=0.0, y_m=C.HALF_TRACK, height_m=height_m, length_m=0.3, width_m=0.1)
    return Scenario(
        "bump", f"left wheel on a {height_m * 100:g} cm bump: level; drive off it, level again", 7.0,
        on_uneven_ground(), terrain=(bump,),
        timeline=(stand(), remote(3.0, Mode=2, SpeedX=0.4), remote(4.5, SpeedX=0.0)),
        checks=(never_fallen(), roll_below(LEVEL, 2.0, 3.0), travels_past(0.3), roll_below(LEVEL, 6.0),
                recovers(), no_deadline_miss()))


# -- step-down: drive off a step ----------------------------------------------------------------
def step_down_scenario(height_m: float = 0.1, speed_mps: float = 0.8) -> Scenario:
    """Drive at ``speed_mps`` off a step ``height_m`` high, 0.5 m ahead, then stop."""
    if height_m <= 0:
        raise ValueError(f"height_m must be > 0, got {height_m}")
    step = TerrainFeature.step(x_m=0.5, height_m=-height_m)
    return Scenario(
        "step-down", f"drive at {speed_mps:g} m/s off a {height_m * 100:g} cm step, then stop", 6.5,
        lambda physics: physics.reset_standing(leg_length_m=0.17), terrain=(step,),
        timeline=(stand(), remote(0.5, Mode=2, SpeedX=speed_mps), remote(2.5, SpeedX=0.0)),
        checks=(travels_past(0.8), never_fallen(), falls_safely(), recovers(), no_deadline_miss()))


# -- turn-fast: a curve at speed ----------------------------------------------------------------
def turn_fast_scenario(speed_mps: float = 1.5, yaw_rate: float = 2.0) -> Scenario:
    """Drive at ``speed_mps``, turn a half circle at ``yaw_rate`` rad/s, straighten, stop.

    Centripetal acceleration v w; the robot must lean in to keep both wheels down.
    """
    if speed_mps <= 0:
        raise ValueError(f"speed_mps must be > 0, got {speed_mps}")
    # after reaching speed: the controller's set point gets there by 0.5 + v / 2 + 0.25 s
    # (2 m/s^2 S-curve); the margin was set for the 4 m/s^2 slew it had before
    t_turn = 1.0 + speed_mps / 4.0 + 0.5
    t_straight = t_turn + math.pi / yaw_rate
    lean = math.atan(speed_mps * yaw_rate / C.GRAVITY)
    return Scenario(
        "turn-fast", f"{speed_mps:g} m/s, a half circle at {yaw_rate:g} rad/s, leaning in", t_straight + 4.0,
        lambda physics: physics.reset_standing(leg_length_m=0.17),
        timeline=(stand(), remote(0.5, Mode=2, SpeedX=speed_mps), remote(t_turn, YawRate=yaw_rate),
                  remote(t_straight, YawRate=0.0), remote(t_straight + 0.5, SpeedX=0.0)),
        checks=(never_fallen(), both_wheels_down(t_turn, t_straight + 0.5),
                leans_into_turn(yaw_rate, t_turn + 0.5, t_straight, 0.5 * lean),
                never_tips(20 * DEG), recovers(), no_deadline_miss()))


# -- sprint: straight at a speed (the top-speed figure) -----------------------------------------
def sprint_scenario(speed_mps: float = 2.0) -> Scenario:
    """Accelerate to ``speed_mps``, hold it, stop: tracked within 0.1 m/s over 1.5 s and upright.

    Tracking is judged from 1.25 s after a 4 m/s^2 ramp would end, as ``drive`` does (the
    controller's set point, a 2 m/s^2 S-curve, is at 2 m/s 0.5 s before that).
    """
    if speed_mps <= 0:
        raise ValueError(f"speed_mps must be > 0, got {speed_mps}")
    t_steady = 0.5 + speed_mps / 4.0 + 1.25
    t_stop = t_steady + 1.5
    return Scenario(
        "sprint", f"straight at {speed_mps:g} m/s for 1.5 s, stop", t_stop + 3.5,
        lambda physics: physics.reset_standing(leg_length_m=0.17),
        timeline=(stand(), remote(0.5, Mode=2, SpeedX=speed_mps), remote(t_stop, SpeedX=0.0)),
        checks=(speed_tracks(speed_mps, t_steady, t_stop), never_fallen(), never_tips(20 * DEG),
                recovers(), no_deadline_miss()))


SCENARIOS = (slope_scenario(), bump_scenario(), step_down_scenario(), turn_fast_scenario(), sprint_scenario())
