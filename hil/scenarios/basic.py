"""The basic scenarios: balance, stand up, drive, turn, change height."""
from __future__ import annotations

import math

import numpy as np

from wheelleg.emulators.physics import TerrainFeature
from wheelleg.hil.run.scenario import Check, RunData, Scenario, in_window
from wheelleg.hil.scenarios.common import (DEG, drift_below, never_tips, no_deadline_miss, pitch_below,
                                  pitch_steady, remote, stand)

NOMINAL = 0.17  # m
# A parking stand, a block under the front and one under the rear of the body, as a
# team parks a balancing robot: folded on its mechanical stop the robot rests on its
# wheels and the front block (4.3 deg nose down), or, with the body's CoM 6-7 mm or more
# behind the nominal (`--plant com_x_m`), on the rear one (4.8 deg nose up). With the
# front block alone such a robot sat back on its tail (52 deg nose up) before the
# controller ever ran. Rising to 0.17 m lifts the body ~6 cm clear of both.
PARKING_STAND = (TerrainFeature.bump(x_m=0.09, y_m=0.0, height_m=0.125, length_m=0.04, width_m=0.10),
                 TerrainFeature.bump(x_m=-0.09, y_m=0.0, height_m=0.125, length_m=0.04, width_m=0.10))


def standing(leg_length: float = NOMINAL):
    return lambda physics: physics.reset_standing(leg_length_m=leg_length)


def forward_speed(run: RunData) -> np.ndarray:
    """Body speed along its heading (m/s), shape (n,)."""
    s = run.state
    return s["vx"] * np.cos(s["yaw"]) + s["vy"] * np.sin(s["yaw"])


def forward_position(run: RunData) -> np.ndarray:
    s = run.state
    yaw0 = s["yaw"][0]
    return (s["x"] - s["x"][0]) * np.cos(yaw0) + (s["y"] - s["y"][0]) * np.sin(yaw0)


def speed_tracks(target: float, t0: float, t1: float, limit: float = 0.1) -> Check:
    def fn(run: RunData):
        err = in_window(run.state["t"], forward_speed(run), t0, t1, "forward speed") - target
        worst = float(np.max(np.abs(err)))
        return worst < limit, f"max speed error {worst:.3f} m/s over {t0:g}-{t1:g} s (limit {limit:g})"

    return Check(f"speed {target:+g} m/s within {limit:g} in steady state", fn)


def stops_within(t_stop: float, limit_m: float, direction: float) -> Check:
    def fn(run: RunData):
        t, pos = run.state["t"], forward_position(run)
        after = in_window(t, pos, t_stop, np.inf, "travel")
        at_stop = np.interp(t_stop, t, pos)
        travel = float(np.max(direction * (after - at_stop)))
        return travel < limit_m, f"travelled {travel:.3f} m after the stop command (limit {limit_m:g})"

    return Check(f"stops within {limit_m:g} m", fn)


def yaw_reaches(target_rad: float, tol_rad: float, after_s: float) -> Check:
    def fn(run: RunData):
        yaw = np.unwrap(run.state["yaw"])
        turned = in_window(run.state["t"], yaw, after_s, np.inf, "yaw") - yaw[0]
        worst = float(np.max(np.abs(turned - target_rad)))
        return worst < tol_rad, f"yaw {np.degrees(turned[-1]):.1f} deg, worst error {np.degrees(worst):.1f} deg after {after_s:g} s"

    return Check(f"yaw within {tol_rad / DEG:g} deg of {target_rad / DEG:g}", fn)


def height_tracks(target: float, t0: float, t1: float, limit: float = 0.01) -> Check:
    """The body's height, the mean of both legs' true lengths, within ``limit`` (m) of ``target``.

    The legs' difference is not this check's: the roll levelling sets it from the IMU, and an
    IMU mounted 1.5 deg rolled (the tolerance box's edge) levels the body by a leg difference
    of ~8 mm across the 0.315 m between the wheels that nothing on the robot can see. At the
    shortest leg (0.12 m) the lower leg stays at the limit and the other takes the whole
    difference, so judging each leg judged the IMU's mounting (docs/measurements.md, 2026-12-06)."""

    def fn(run: RunData):
        height = 0.5 * (run.window("left_leg_length", t0, t1) + run.window("right_leg_length", t0, t1))
        worst = float(np.max(np.abs(height - target)))
        return worst < limit, f"height error {worst * 1000:.1f} mm at {target:g} m over {t0:g}-{t1:g} s"

    return Check(f"height (the legs' mean) at {target:g} m within {limit * 100:g} cm", fn)


def upright_by(t_s: float, target_leg: float) -> Check:
    """From some time <= t_s on, |pitch| < 5 deg and legs within 1 cm, to the end."""

    def fn(run: RunData):
        s = run.state
        ok = (np.abs(s["pitch"]) < 5 * DEG) & (np.abs(s["left_leg_length"] - target_leg) < 0.01) \
            & (np.abs(s["right_leg_length"] - target_leg) < 0.01)
        bad = np.nonzero(~ok)[0]
        since = float(s["t"][bad[-1] + 1]) if len(bad) and bad[-1] + 1 < len(ok) else (
            float(s["t"][0]) if not len(bad) else float("inf"))
        return since <= t_s, f"upright and at height from {since:.2f} s (by {t_s:g} s)"

    return Check(f"upright within {t_s:g} s", fn)


SCENARIOS = (
    Scenario("balance", "stand still on flat ground for 10 s", 10.0, standing(),
             timeline=(stand(),),
             checks=(pitch_steady(2 * DEG, 5 * DEG, 1.0), drift_below(0.05), no_deadline_miss())),
    Scenario("stand-up", "start folded on the mechanical stop, parked on a stand, rise to 0.17 m and balance",
             5.0, lambda physics: physics.reset_resting(), terrain=PARKING_STAND,
             timeline=(stand(0.0, NOMINAL),),
             checks=(upright_by(2.0, NOMINAL), never_tips(20 * DEG), no_deadline_miss())),
    Scenario("drive", "1 m/s forward for 3 s, stop, 1 m/s back for 3 s, stop", 11.0, standing(),
             timeline=(stand(), remote(1.0, Mode=2, SpeedX=1.0), remote(4.0, SpeedX=0.0),
                       remote(6.0, SpeedX=-1.0), remote(9.0, SpeedX=0.0)),
             checks=(speed_tracks(1.0, 2.5, 4.0), stops_within(4.0, 0.5, 1.0),
                     speed_tracks(-1.0, 7.5, 9.0), stops_within(9.0, 0.5, -1.0),
                     never_tips(20 * DEG), no_deadline_miss())),
    Scenario("turn", "turn 90 deg in place at 1 rad/s", 5.0, standing(),
             timeline=(stand(), remote(1.0, Mode=2, YawRate=1.0),
                       remote(1.0 + math.pi / 2, YawRate=0.0)),
             checks=(yaw_reaches(math.pi / 2, 5 * DEG, 4.0), drift_below(0.10), no_deadline_miss())),
    Scenario("height", "leg length 0.12 -> 0.25 -> 0.17 m while balancing", 10.0, standing(),
             timeline=(stand(0.0, 0.12), remote(3.5, LegLength=0.25), remote(7.0, LegLength=0.17)),
             checks=(height_tracks(0.12, 2.5, 3.5), height_tracks(0.25, 6.0, 7.0), height_tracks(0.17, 9.0, 10.0),
                     pitch_below(5 * DEG, 1.0), no_deadline_miss())),
)
