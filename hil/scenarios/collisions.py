"""Pushes, impacts and walls.

Each scenario comes from a factory with its size (push impulse N s, object
speed m/s, wall height m); the default instance is registered. Checks read the
trace only: the robot either recovers (upright, at rest, near its spot) or
falls safely (FALLEN in the heartbeat and, from then on, no torque commanded).
"""
from __future__ import annotations

import numpy as np

from wheelleg.controller.modes import Mode
from wheelleg.emulators.physics import TerrainFeature
from wheelleg.hil.run.scenario import Action, Check, RunData, Scenario
from wheelleg.hil.scenarios.basic import standing
from wheelleg.hil.scenarios.common import (CURRENT_OFF_A, DEG, TORQUE_OFF_NM, no_deadline_miss, push, remote, stand,
                                  torque_after)

FALLEN = int(Mode.FALLEN)  # rig.dbc Heartbeat.Mode carries the controller's Mode values
SUDDEN_S = 0.1  # s, a sudden impulse: a kick or a shove
STEADY_S = 1.0  # s, a steady push: a hand leaning on the body
RECOVER_S = 3.0  # s between pushes: back to rest, most of the way home (it returns at ~0.15 m/s)
TORQUE_OFF_GRACE_S = 0.01  # s, the tick that saw the fall may still have sent its torques
# m, "back near its spot": the controller returns to where it stood by wheel odometry,
# which misses what the wheels skid under a sudden push (60 N > mu m g = 45 N)
HOME_M = 0.5
HOMING_S = 4.0  # s added after the last push: ~1 m back home at ~0.15 m/s (POSITION_ERROR_LIMIT), then at rest
DIRECTIONS = {"front": (-1.0, 0.0, 0.0), "side": (0.0, -1.0, 0.0)}  # force directions: from the front / left


# -- checks ---------------------------------------------------------------------
def fall_time(run: RunData) -> float | None:
    """Time (s) of the first FALLEN heartbeat, or None."""
    t, mode = run.heartbeat["t"], run.heartbeat["Mode"]
    hits = t[mode == FALLEN]
    return float(hits[0]) if len(hits) else None


def falls_safely() -> Check:
    """If it fell: from the FALLEN heartbeat on, no hip torque and no wheel current commanded."""

    def fn(run: RunData):
        t_fall = fall_time(run)
        if t_fall is None:
            return True, "did not fall"
        worst_hip, worst_wheel = torque_after(run, t_fall + TORQUE_OFF_GRACE_S)
        ok = worst_hip < TORQUE_OFF_NM and worst_wheel < CURRENT_OFF_A
        return ok, (f"fell at {t_fall:.2f} s; after it max |hip torque| {worst_hip:.3f} N m, "
                    f"max |wheel current| {worst_wheel:.3f} A (off below {TORQUE_OFF_NM:g}, {CURRENT_OFF_A:g})")

    return Check("falls safely: no torque after FALLEN", fn)


def recovers(last_s: float = 1.0, tilt: float = 5 * DEG, speed: float = 0.1) -> Check:
    """Never FALLEN, and over the last ``last_s``: |pitch|, |roll| < tilt, speed < ``speed`` m/s."""

    def fn(run: RunData):
        t_fall = fall_time(run)
        if t_fall is not None:
            return False, f"fell at {t_fall:.2f} s"
        t_end = float(run.state["t"][-1])
        pitch = float(np.max(np.abs(run.window("pitch", t_end - last_s))))
        roll = float(np.max(np.abs(run.window("roll", t_end - last_s))))
        v = float(np.max(np.hypot(run.window("vx", t_end - last_s), run.window("vy", t_end - last_s))))
        ok = pitch < tilt and roll < tilt and v < speed
        return ok, (f"last {last_s:g} s: max |pitch| {pitch / DEG:.1f} deg, |roll| {roll / DEG:.1f} deg, "
                    f"speed {v:.3f} m/s (limits {tilt / DEG:g} deg, {speed:g} m/s)")

    return Check("recovers: upright and at rest at the end", fn)


def ends_near_start(limit_m: float) -> Check:
    def fn(run: RunData):
        x, y = run.state["x"], run.state["y"]
        dist = float(np.hypot(x[-1] - x[0], y[-1] - y[0]))
        return dist < limit_m, f"ends {dist:.2f} m from its start (limit {limit_m:g})"

    return Check(f"back within {limit_m:g} m of its spot", fn)


def pushed_robot_moved(min_m: float = 0.01) -> Check:
    """The push reached the robot: it moved at least ``min_m`` (guards against a no-op push)."""

    def fn(run: RunData):
        x, y = run.state["x"], run.state["y"]
        moved = float(np.max(np.hypot(x - x[0], y - y[0])))
        return moved >= min_m, f"moved up to {moved * 100:.1f} cm (at least {min_m * 100:g})"

    return Check("the push moved the robot", fn)


# -- push: steady and sudden, front and side ----------------------------------------------------
def push_scenario(impulse_ns: float = 5.0, kinds=("sudden", "steady"), sides=("front", "side")) -> Scenario:
    """Pushes at body height (the CoM), each of ``impulse_ns`` N s, one after another.

    sudden: impulse_ns / 0.1 s for 0.1 s; steady: impulse_ns / 1 s for 1 s.
    From the front pushes backwards; from the side pushes to the right. The
    robot must come back upright, at rest, within HOME_M of where it stood.
    """
    if impulse_ns <= 0:
        raise ValueError(f"impulse_ns must be > 0, got {impulse_ns}")
    timeline, t = [stand()], 1.0
    for side in sides:
        for kind in kinds:
            duration = SUDDEN_S if kind == "sudden" else STEADY_S
            force = np.array(DIRECTIONS[side]) * impulse_ns / duration
            timeline += push(t, force, duration)
            t += duration + RECOVER_S
    return Scenario(
        "push", f"{impulse_ns:g} N s pushes at body height: {', '.join(kinds)} from the {' and '.join(sides)}",
        t + HOMING_S, standing(), timeline=tuple(timeline),
        checks=(pushed_robot_moved(), falls_safely(), recovers(), ends_near_start(HOME_M), no_deadline_miss()))


# -- impact: a moving object strikes the body ---------------------------------------------------
IMPACT_MASS_KG = 0.5  # a football-sized hit
IMPACT_RADIUS_M = 0.06
_PARKED = (3.0, 3.0, IMPACT_RADIUS_M)  # where the object waits, on the floor, out of the way


def launch(t_s: float, position_m, velocity_mps, index: int = 0) -> Action:
    def fn(rig):
        rig.physics.launch_projectile(index, position_m, velocity_mps)
        return {"position_m": list(position_m), "velocity_mps": list(velocity_mps)}

    return Action(t_s, "launch", fn)


def impact_scenario(speed_mps: float = 4.0, mass_kg: float = IMPACT_MASS_KG) -> Scenario:
    """A ball of ``mass_kg`` thrown at ``speed_mps`` strikes the body at CoM height,
    first from the front, then from the side (the same ball, relaunched)."""
    if speed_mps <= 0:
        raise ValueError(f"speed_mps must be > 0, got {speed_mps}")
    ball = TerrainFeature.projectile(mass_kg, IMPACT_RADIUS_M, _PARKED, (0.0, 0.0, 0.0))
    # launched 0.25 m from the body face, level with the CoM; it drops < 1 cm on the way
    h = 0.17 + 0.02 + 0.05  # leg + CoM above hips + wheel radius: the CoM's height at 0.17 m legs
    front = launch(1.0, (0.13 + 0.25 + IMPACT_RADIUS_M, 0.0, h), (-speed_mps, 0.0, 0.0))
    side = launch(4.0, (0.0, 0.12 + 0.25 + IMPACT_RADIUS_M, h), (0.0, -speed_mps, 0.0))
    return Scenario(
        "impact", f"a {mass_kg:g} kg ball at {speed_mps:g} m/s strikes the body, front then side", 7.0,
        standing(), terrain=(ball,), timeline=(stand(), front, side),
        checks=(pushed_robot_moved(), falls_safely(), recovers(), ends_near_start(HOME_M), no_deadline_miss()))


# -- wall: drive into a low wall ----------------------------------------------------------------
def wall_scenario(speed_mps: float = 0.4, height_m: float = 0.08) -> Scenario:
    """Drive at ``speed_mps`` into a wall ``height_m`` high, 0.5 m ahead, keep
    pushing for 2 s, then stop. It must stay up (or fall safely) and end at rest.

    0.08 m is above the axle (wheel radius 0.05 m), so the wheels cannot climb
    it, and below the body (its underside ~0.2 m up), so only the wheels hit.
    """
    if height_m <= 0 or speed_mps <= 0:
        raise ValueError(f"height_m and speed_mps must be > 0, got {height_m}, {speed_mps}")
    wall = TerrainFeature.wall(x_m=0.5, height_m=height_m)
    t_stop = 0.5 + 0.5 / speed_mps + 2.0  # about 2 s against the wall
    return Scenario(
        "wall", f"drive at {speed_mps:g} m/s into a {height_m * 100:g} cm wall, push 2 s, stop", t_stop + 4.0,
        standing(), terrain=(wall,),
        timeline=(stand(), remote(0.5, Mode=2, SpeedX=speed_mps), remote(t_stop, SpeedX=0.0)),
        checks=(reaches_wall(0.5), falls_safely(), recovers(), no_deadline_miss()))


def reaches_wall(x_face: float, radius_m: float = 0.05) -> Check:
    """The wheels reach the wall: the body CoM (over the axles when upright)
    comes within a wheel radius + 1 cm of its face."""

    def fn(run: RunData):
        gap = x_face - radius_m - float(np.max(run.state["x"]))
        return gap < 0.01, f"closest the CoM came to a wheel radius off the wall: {gap * 100:.1f} cm (within 1)"

    return Check("drives up to the wall", fn)


SCENARIOS = (push_scenario(), impact_scenario(), wall_scenario())
