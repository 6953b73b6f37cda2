"""Jumps, drops, falls, E-stop and pose set points.

The sized scenarios come from factories (``jump_scenario(clearance_m)``,
``jump_step_scenario(step_height_m)``, ``drop_scenario(height_m)``) so a
search can find the largest that passes; the default instances are in
``SCENARIOS``. Every check reads the trace only: /sim/state (wheel normal
forces and clearances, pose), the heartbeat's Mode, and the commanded hip
torques and wheel currents.
"""
from __future__ import annotations

import math

import numpy as np

from wheelleg.controller import params as P
from wheelleg.controller.modes import Mode
from wheelleg.emulators.physics import TerrainFeature
from wheelleg.hil.run.scenario import Check, NotJudged, RunData, Scenario
from wheelleg.hil.scenarios.common import (CURRENT_OFF_A, DEG, TORQUE_OFF_NM, first_mode, no_deadline_miss, push,
                                  remote, stand, level_within, torque_after, tracks)

# rig.dbc Heartbeat.Mode carries the controller's Mode values
ESTOP, STAND_UP, BALANCE, MOVE, JUMP, AIRBORNE, FALLEN = (
    int(m) for m in (Mode.ESTOP, Mode.STAND_UP, Mode.BALANCE, Mode.MOVE, Mode.JUMP, Mode.AIRBORNE, Mode.FALLEN))
MODE_NAMES = {int(m): m.name for m in Mode}
NOMINAL = 0.17  # m, standing leg length
OFF_GROUND_N = 0.5  # N, a wheel normal force below this is "off the ground" (contact noise ~0)
REMOTE_PERIOD_S = 0.02  # s, the remote's frame period: a switch reaches the bus within it
CONTROL_PERIOD_S = P.CONTROL_PERIOD  # s


def standing(leg_length: float = NOMINAL, drop_height_m: float = 0.0, x_m: float = 0.0):
    return lambda physics: physics.reset_standing(leg_length_m=leg_length, drop_height_m=drop_height_m, x_m=x_m)


# -- trace helpers -------------------------------------------------------------------
def airborne_spans(run: RunData) -> list[tuple[float, float]]:
    """(start, end) s of the spans with both wheels' normal force below OFF_GROUND_N."""
    s = run.state
    off = (s["left_normal_force"] < OFF_GROUND_N) & (s["right_normal_force"] < OFF_GROUND_N)
    edges = np.diff(np.concatenate(([0], off.astype(int), [0])))
    starts, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0] - 1
    return [(float(s["t"][a]), float(s["t"][b])) for a, b in zip(starts, ends)]


def peak_clearance(run: RunData, t0: float = 0.0) -> float:
    """Highest clearance (m) of the lower wheel's bottom above the ground below it, after t0."""
    low = np.minimum(run.window("left_wheel_clearance", t0), run.window("right_wheel_clearance", t0))
    if not len(low):
        raise NotJudged(f"no wheel clearance samples after {t0:g} s")
    return float(np.max(low))


# -- checks --------------------------------------------------------------------------
def leaves_ground(min_s: float = 0.05) -> Check:
    def fn(run: RunData):
        spans = airborne_spans(run)
        longest = max((b - a for a, b in spans), default=0.0)
        return longest >= min_s, f"longest time with both wheels off the ground {longest * 1000:.0f} ms (need {min_s * 1000:g})"

    return Check(f"both wheels leave the ground for {min_s * 1000:g} ms", fn)


def clearance_at_least(min_m: float, after_s: float = 0.0) -> Check:
    def fn(run: RunData):
        peak = peak_clearance(run, after_s)
        return peak >= min_m, f"peak clearance of the lower wheel {peak * 100:.1f} cm (need {min_m * 100:g})"

    return Check(f"peak wheel clearance >= {min_m * 100:g} cm", fn)


def mode_seen(mode: int, after_s: float = 0.0) -> Check:
    def fn(run: RunData):
        t = first_mode(run, mode, after_s)
        return t is not None, f"first {MODE_NAMES[mode]} heartbeat at {t:.3f} s" if t is not None else f"never {MODE_NAMES[mode]}"

    return Check(f"heartbeat shows {MODE_NAMES[mode]}", fn)


def never_fallen() -> Check:
    def fn(run: RunData):
        t = first_mode(run, FALLEN)
        return t is None, "never FALLEN" if t is None else f"FALLEN at {t:.3f} s"

    return Check("never FALLEN", fn)


def upright_at_end(last_s: float = 1.0, tilt_rad: float = 5 * DEG, mode: int = BALANCE) -> Check:
    """Over the last ``last_s``: |pitch|, |roll| below tilt, both wheels loaded, heartbeat in ``mode``."""

    def fn(run: RunData):
        t_end = float(run.state["t"][-1])
        t0 = t_end - last_s
        tilt = max(float(np.max(np.abs(run.window("pitch", t0)))), float(np.max(np.abs(run.window("roll", t0)))))
        loaded = float(np.min(np.minimum(run.window("left_normal_force", t0), run.window("right_normal_force", t0))))
        hb_t, hb_m = run.heartbeat["t"], run.heartbeat["Mode"]
        modes = set(int(m) for m in hb_m[hb_t >= t0])
        ok = tilt < tilt_rad and loaded > 5.0 and modes == {mode}
        return ok, (f"last {last_s:g} s: max tilt {tilt / DEG:.1f} deg (limit {tilt_rad / DEG:g}), "
                    f"min wheel load {loaded:.1f} N, modes {sorted(MODE_NAMES[m] for m in modes)}")

    return Check(f"upright and {MODE_NAMES[mode]} over the last {last_s:g} s", fn)


def on_top_of_step(edge_x_m: float, height_m: float) -> Check:
    """At the end both wheels are past the edge and the body stands height_m higher than at the start."""

    def fn(run: RunData):
        s = run.state
        rise = float(s["z"][-1] - s["z"][0])
        past = float(s["x"][-1] - edge_x_m)
        ok = past > 0.1 and abs(rise - height_m) < 0.03
        return ok, f"body {past * 100:.1f} cm past the edge (need 10), risen {rise * 100:.1f} cm (step {height_m * 100:g})"

    return Check(f"ends on top of the {height_m * 100:g} cm step", fn)


def torque_off_after_fall(grace_s: float = CONTROL_PERIOD_S) -> Check:
    """From the first FALLEN heartbeat (plus one tick) until an operator re-enable: no torque."""

    def fn(run: RunData):
        t_fall = first_mode(run, FALLEN)
        if t_fall is None:
            return False, "never FALLEN"
        reenables = [e["t"] for e in run.events_of("operator") if e.get("Reenable") and e["t"] > t_fall]
        t_end = reenables[0] if reenables else np.inf
        hip, wheel = torque_after(run, t_fall + grace_s, t_end)
        ok = hip < TORQUE_OFF_NM and wheel < CURRENT_OFF_A
        return ok, (f"FALLEN at {t_fall:.3f} s; until re-enable max |hip torque| {hip:.3f} N m, "
                    f"max |wheel current| {wheel:.3f} A")

    return Check("torque off from FALLEN until re-enable", fn)


# Whether a fallen body can stand again is whether its wheels are on the floor: then the
# recovery stand rolls them under it (lying on its nose or its tail); on its back, on its
# side or up on its nose with the wheels in the air, the legs only wave.
WHEEL_ON_FLOOR_N = 1.0  # N of normal force a wheel needs to count as on the floor
LYING_WINDOW_S = 0.1  # s before the re-enable over which it is judged (the mean force)


def lying(run: RunData, t_s: float) -> tuple[bool, str]:
    """(whether both wheels are on the floor at ``t_s``, where the body lies, in words)."""
    i = min(int(np.searchsorted(run.state["t"], t_s)), len(run.state["t"]) - 1)
    pitch, roll = float(run.state["pitch"][i]), float(run.state["roll"][i])
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, math.cos(pitch) * math.cos(roll)))))
    loads = [float(np.mean(run.window(f"{side}_normal_force", t_s - LYING_WINDOW_S, t_s))) for side in ("left", "right")]
    on_floor = min(loads) > WHEEL_ON_FLOOR_N
    axle_up = math.cos(pitch) * math.sin(roll)  # z of the body's y axis: its wheels' axle
    where = ("on its back" if tilt > 120 else "on its side" if abs(axle_up) > math.sin(math.radians(45))
             else f"on its {'nose' if pitch > 0 else 'tail'}")
    return on_floor, f"{where} ({tilt:.0f} deg from upright, wheels {loads[0]:.1f}/{loads[1]:.1f} N)"


def stands_up_where_it_can(last_s: float = 1.0) -> Check:
    """After the operator's re-enable: upright (``upright_at_end``) if the body lay with both wheels
    on the floor, from where the recovery stand can roll them under it; lying with a wheel in
    the air (on its back, its side), which no stand-up of this robot leaves, it stays FALLEN
    with the torque off (from a tick after the re-enable to the end). Where a hard fall ends
    is the fall's (a tumble at 4-5 m/s); what the program does there is the program's."""
    upright = upright_at_end(last_s)

    def fn(run: RunData):
        reenables = [e["t"] for e in run.events_of("operator") if e.get("Reenable")]
        if not reenables:
            raise NotJudged("no re-enable in the timeline")
        can_stand, where = lying(run, reenables[0])
        if can_stand:
            ok, detail = upright.fn(run)
            return ok, f"lay {where} at the re-enable; {detail}"
        hip, wheel = torque_after(run, reenables[0] + CONTROL_PERIOD_S)
        modes = run.heartbeat["Mode"]
        ok = hip < TORQUE_OFF_NM and wheel < CURRENT_OFF_A and len(modes) > 0 and int(modes[-1]) == FALLEN
        return ok, (f"lay {where} at the re-enable, a wheel in the air: after it max |hip torque| "
                    f"{hip:.3f} N m, max |wheel current| {wheel:.3f} A, last mode "
                    f"{MODE_NAMES[int(modes[-1])] if len(modes) else 'none'}")

    return Check(f"re-enabled: upright over the last {last_s:g} s, or off where it cannot stand", fn)


def estops_cut_torque(expected_modes: tuple) -> Check:
    """Each E-stop event: the ESTOP heartbeat within one remote period plus one control
    period, no torque commanded after it until the switch leaves E-stop, and the
    mode just before it was the expected one."""

    def fn(run: RunData):
        events = [e for e in run.events_of("operator") if "Mode" in e]
        stops = [(i, e) for i, e in enumerate(events) if e["Mode"] == 0]
        if len(stops) != len(expected_modes):
            return False, f"{len(stops)} E-stops in the timeline, expected {len(expected_modes)}"
        hb_t, hb_m = run.heartbeat["t"], run.heartbeat["Mode"]
        notes, ok = [], True
        for (i, e), expected in zip(stops, expected_modes):
            before = hb_m[hb_t < e["t"]]
            was = int(before[-1]) if len(before) else -1
            t_stop = first_mode(run, ESTOP, e["t"])
            t_resume = events[i + 1]["t"] if i + 1 < len(events) else np.inf
            if t_stop is None:
                ok = False
                notes.append(f"{MODE_NAMES.get(was, was)}: no ESTOP")
                continue
            latency = t_stop - e["t"]
            hip, wheel = torque_after(run, t_stop, t_resume)
            good = was == expected and latency <= REMOTE_PERIOD_S + CONTROL_PERIOD_S + 1e-6 \
                and hip < TORQUE_OFF_NM and wheel < CURRENT_OFF_A
            ok = ok and good
            notes.append(f"{MODE_NAMES.get(was, was)}: {latency * 1000:.0f} ms, then {hip:.3f} N m / {wheel:.3f} A")
        return ok, "; ".join(notes)

    return Check("E-stop cuts torque from every mode", fn)


def mean_leg_tracks(target: float, t0: float, t1: float, tol: float = 0.01) -> Check:
    def fn(run: RunData):
        mean = 0.5 * (run.window("left_leg_length", t0, t1) + run.window("right_leg_length", t0, t1))
        worst = float(np.max(np.abs(mean - target)))
        return worst < tol, f"mean leg length worst error {worst * 1000:.1f} mm at {target:g} m over {t0:g}-{t1:g} s"

    return Check(f"height {target:g} m over {t0:g}-{t1:g} s", fn)


# -- scenarios -----------------------------------------------------------------------
def _positive(name: str, value: float, upper: float) -> None:
    if not (0.0 < value <= upper):
        raise ValueError(f"{name} must be in (0, {upper:g}], got {value}")


def jump_scenario(clearance_m: float = 0.2) -> Scenario:
    """Jump in place from balance; pass if the lower wheel clears ``clearance_m``."""
    _positive("clearance_m", clearance_m, 2.0)
    return Scenario(
        "jump", f"jump in place, lower wheel clears {clearance_m * 100:g} cm, land upright", 3.5, standing(),
        timeline=(stand(), remote(0.8, Jump=1), remote(1.0, Jump=0)),
        checks=(mode_seen(JUMP), leaves_ground(), clearance_at_least(clearance_m, 0.5),
                never_fallen(), upright_at_end(0.8), no_deadline_miss()))


def jump_step_scenario(step_height_m: float = 0.15, approach_m: float = 0.72) -> Scenario:
    """Stand ``approach_m`` (m, body to the step's edge) before a step and JumpForward onto it.

    The default approach suits the run-up JumpForward takes (it thrusts only at
    its speed, ~0.55 m on), so the wheels pass the edge near the top of the jump.
    """
    _positive("step_height_m", step_height_m, 1.0)
    _positive("approach_m", approach_m, 5.0)
    edge = approach_m
    return Scenario(
        "jump-step", f"jump forward onto a {step_height_m * 100:g} cm step, balance on top", 4.0, standing(),
        terrain=(TerrainFeature.step(x_m=edge, height_m=step_height_m),),
        timeline=(stand(), remote(0.8, JumpForward=1), remote(1.0, JumpForward=0)),
        checks=(mode_seen(JUMP), leaves_ground(), never_fallen(), on_top_of_step(edge, step_height_m),
                upright_at_end(0.8), no_deadline_miss()))


def drop_scenario(height_m: float = 0.5) -> Scenario:
    """Released at ``height_m`` (lower wheel above the ground) with legs at 0.17 m."""
    _positive("height_m", height_m, 5.0)
    return Scenario(
        "drop", f"released {height_m * 100:g} cm above the ground, lands and balances", 3.0,
        standing(drop_height_m=height_m), timeline=(stand(),),
        checks=(mode_seen(AIRBORNE), never_fallen(), upright_at_end(1.0), no_deadline_miss()))


def fall_scenario(force_n: float = 40.0, duration_s: float = 1.0) -> Scenario:
    """A push it cannot save: detected, torque off; lying, the operator re-enables and it
    stands where it can (``stands_up_where_it_can``).

    The default leans on the body with 40 N (0.9 of its weight) for 1 s: holding
    that would take a lean past the fall limits, so any balance law topples. The
    wheels run with it to their top speed and the body goes over at 4-5 m/s; where
    that tumble ends (on its nose or tail, or over onto its back or side, from where
    it cannot stand) turns on a millimetre of the run (seed, controller, plant), so
    the check judges the program's answer to where it lies, not where that is.
    """
    _positive("force_n", force_n, 500.0)
    _positive("duration_s", duration_s, 2.5)
    return Scenario(
        "fall", f"{force_n:g} N push for {duration_s:g} s topples it; torque off; re-enable stands it where its wheels are down", 7.0,
        standing(),
        timeline=(stand(), *push(0.5, (force_n, 0.0, 0.0), duration_s), remote(3.0, Reenable=1),
                  remote(3.2, Reenable=0)),
        checks=(mode_seen(FALLEN), torque_off_after_fall(), mode_seen(STAND_UP, 3.0),
                stands_up_where_it_can(1.0), no_deadline_miss()))


ESTOP_S = 0.06  # s the switch stays on E-stop: torque off, the robot barely sags


LIFT_N = 55.0  # N up at the CoM (weight 45 N): a hand lifting the robot off the floor
LIFT_S = 0.4  # s


def estop_scenario() -> Scenario:
    """E-stop flicked in STAND_UP, BALANCE, MOVE, JUMP and AIRBORNE (lifted by a hand);
    each time released again."""
    def flick(t, back):
        return (remote(t, Mode=0), remote(t + ESTOP_S, Mode=back))
    return Scenario(
        "estop", "E-stop in stand-up, balance, move, jump and lifted; torque off within a period each time", 8.5,
        standing(), timeline=(remote(0.0, Mode=1, LegLength=0.12), *flick(0.1, 1), remote(0.8, LegLength=NOMINAL),
                              *flick(1.5, 1), remote(2.5, Mode=2, SpeedX=0.3), *flick(3.0, 2),
                              remote(3.8, SpeedX=0.0, Mode=1), remote(4.8, Jump=1), remote(4.9, Jump=0),
                              *flick(4.9, 1), *push(6.0, (0.0, 0.0, LIFT_N), LIFT_S), *flick(6.3, 1)),
        checks=(estops_cut_torque((STAND_UP, BALANCE, MOVE, JUMP, AIRBORNE)), never_fallen(), upright_at_end(1.0),
                no_deadline_miss()))


# rad: how far the IMU's board may sit off the body's frame on a real build (docs/robot.md,
# "The tolerance box": the chip on its board, the standoffs, the plate; +-1.5 deg), which
# nothing on this robot measures: a level stance is judged within it plus the 1 deg hold.
IMU_MOUNT_TILT_RAD = 1.5 * DEG
POSE_HOLD_RAD = 1 * DEG


def pose_scenario() -> Scenario:
    """Pitch, roll, height and then yaw set points while standing, one after the other.

    Pitch and roll are judged as their change from the level stance the robot holds at
    7.5-8 s (every set point zero), and that stance within the IMU mount's tolerance:
    a board mounted 1.5 deg off turns every pose by 1.5 deg, which no program can see
    (a wheel-legged robot's legs give no reference for the body's pitch over the floor).
    """
    yaw_turn = math.pi / 4
    level = (7.5, 8.0)
    return Scenario(
        "pose", "pitch +-0.1 rad, roll +-0.1 rad, height 0.22 m, then a 45 deg yaw while standing", 10.5,
        standing(),
        timeline=(stand(), remote(0.5, Pitch=0.1), remote(2.0, Pitch=-0.1), remote(3.5, Pitch=0.0, Roll=0.1),
                  remote(5.0, Roll=-0.1), remote(6.5, Roll=0.0, LegLength=0.22),
                  remote(8.0, Mode=2, YawRate=1.0), remote(8.0 + yaw_turn, YawRate=0.0)),
        checks=(tracks("pitch", 0.1, 1.5, 2.0, POSE_HOLD_RAD, level=level),
                tracks("pitch", -0.1, 3.0, 3.5, POSE_HOLD_RAD, level=level),
                tracks("roll", 0.1, 4.5, 5.0, POSE_HOLD_RAD, level=level),
                tracks("roll", -0.1, 6.0, 6.5, POSE_HOLD_RAD, level=level),
                level_within("pitch", *level, IMU_MOUNT_TILT_RAD + POSE_HOLD_RAD),
                level_within("roll", *level, IMU_MOUNT_TILT_RAD + POSE_HOLD_RAD),
                mean_leg_tracks(0.22, 7.5, 10.5), tracks("yaw", yaw_turn, 9.5, 10.5, 2 * DEG),
                never_fallen(), no_deadline_miss()))


SCENARIOS = (jump_scenario(), jump_step_scenario(), drop_scenario(), fall_scenario(), estop_scenario(),
             pose_scenario())
