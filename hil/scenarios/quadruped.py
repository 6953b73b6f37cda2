"""The quadruped's scenarios: stand up, balance stand, push, trot, turn, recovery stand.

Each starts from a pose of the plant (standing, lying folded, on its side),
acts only as the outside world would (the remote's QuadOperator, a push) and
is judged from the trace: the ground truth on /sim/state (body centre ``z``
over the floor, the remote's Height; roll, pitch, yaw; velocities;
``body_on_ground``) and the heartbeat's Mode (the quadruped's modes,
``wheelleg.controller.quadruped.modes.Mode``). The E-stop and offline
scenarios are in quadruped_faults.py.
"""
from __future__ import annotations

import math

import numpy as np

from wheelleg.controller.quadruped.modes import Mode
from wheelleg.emulators.quadruped import description as D
from wheelleg.hil.run.scenario import Check, RunData, Scenario
from wheelleg.hil.scenarios.basic import forward_speed, yaw_reaches
from wheelleg.hil.scenarios.common import DEG, first_mode, max_abs, no_deadline_miss, push, remote, tracks

ROBOT = "quadruped"
HEIGHT_M = 0.21  # m, the stand: body centre over the floor (the remote's Height; the controller's nominal)
STAND_S = 3.5  # s from the first request to a settled balance stand (stand-up takes ~2 s)
REMOTE_PERIOD_S = D.REMOTE_PERIOD_S  # s: a switch reaches the bus within it
PERIOD_S = D.CONTROL_PERIOD_S  # s


# -- starts ------------------------------------------------------------------------------------
def standing(physics) -> None:
    """Standing at the stand height, motors off: the controller's stand-up takes it from there."""
    physics.reset_standing(HEIGHT_M - D.FOOT_RADIUS_M)


def lying(physics) -> None:
    physics.reset_lying()


def on_its_side(physics) -> None:
    physics.reset_lying(on_side=True)


def stand_request(t_s: float = 0.1):
    """The operator asks for the balance stand (stand up first when not standing)."""
    return remote(t_s, Mode=int(Mode.BALANCE_STAND), Height=HEIGHT_M)


def quad_scenario(name: str, summary: str, duration_s: float, start, timeline=(), checks=(), tags=()) -> Scenario:
    """A scenario of the quadruped; every one also checks for deadline misses."""
    return Scenario(name, summary, duration_s, start, tuple(timeline), (*checks, no_deadline_miss()),
                    tags=tags, robot=ROBOT)


# -- checks --------------------------------------------------------------------------------------
def tilt_below(limit_rad: float, t0: float = 0.0, t1: float = np.inf) -> Check:
    """max(|roll|, |pitch|) in [t0, t1) below ``limit_rad``."""
    def fn(run: RunData):
        worst = max(max_abs(run.window("roll", t0, t1), f"roll {t0:g}-{t1:g} s"),
                    max_abs(run.window("pitch", t0, t1), f"pitch {t0:g}-{t1:g} s"))
        span = f"{t0:g}-{t1:g} s" if np.isfinite(t1) else f"from {t0:g} s"
        return worst < limit_rad, f"max |roll|, |pitch| {worst / DEG:.1f} deg {span}"

    return Check(f"|roll|, |pitch| < {limit_rad / DEG:g} deg from {t0:g} s", fn)


def settles_at_height(target_m: float, request_s: float, within_s: float, tol_m: float = 0.01) -> Check:
    """Body centre within ``tol_m`` of ``target_m`` from some time <= request + ``within_s`` to the end."""
    def fn(run: RunData):
        t, z = run.state["t"], run.state["z"]
        off = np.flatnonzero(np.abs(z - target_m) >= tol_m)  # samples away from the height
        if not len(off):
            settled = float(t[0])
        elif off[-1] + 1 < len(t):
            settled = float(t[off[-1] + 1])  # the first sample after the last one away
        else:
            settled = None
            return False, f"never settles within {tol_m * 1000:g} mm of {target_m:g} m (ends at {z[-1]:.3f} m)"
        took = settled - request_s
        return took <= within_s, f"at {target_m:g} m +-{tol_m * 1000:g} mm {took:.2f} s after the request"

    return Check(f"stands at {target_m:g} m within {within_s:g} s", fn)


def mode_reached(mode: Mode, after_s: float = 0.0) -> Check:
    def fn(run: RunData):
        t = first_mode(run, int(mode), after_s)
        return t is not None, f"{mode.name} at {t:.3f} s" if t is not None else f"never {mode.name}"

    return Check(f"{mode.name} in the heartbeat", fn)


def upright_at_end(last_s: float = 1.0, mode: Mode = Mode.BALANCE_STAND, tilt_rad: float = 5 * DEG,
                   height_m: float = HEIGHT_M, height_tol_m: float = 0.02) -> Check:
    """Over the last ``last_s``: |roll|, |pitch| < ``tilt_rad``, body centre near ``height_m``, in ``mode``,
    nothing but the feet on the ground."""
    def fn(run: RunData):
        t_end = float(run.state["t"][-1])
        t0 = t_end - last_s
        tilt = max(max_abs(run.window("roll", t0)), max_abs(run.window("pitch", t0)))
        sag = max_abs(run.window("z", t0) - height_m)
        down = float(np.max(run.window("body_on_ground", t0)))
        modes = run.heartbeat["Mode"][run.heartbeat["t"] >= t0]
        ok = tilt < tilt_rad and sag < height_tol_m and down == 0.0 and len(modes) and np.all(modes == int(mode))
        return ok, (f"last {last_s:g} s: tilt {tilt / DEG:.1f} deg, height off by {sag * 1000:.0f} mm, "
                    f"{'body down, ' if down else ''}modes {sorted({Mode(int(m)).name for m in modes})}")

    return Check(f"upright in {mode.name} at {height_m:g} m at the end", fn)


def mean_speed(target_mps: float, t0: float, t1: float, tol_mps: float = 0.05) -> Check:
    def fn(run: RunData):
        t = run.state["t"]
        window = forward_speed(run)[(t >= t0) & (t < t1)]
        mean = float(np.mean(window)) if len(window) else math.nan
        return abs(mean - target_mps) <= tol_mps, f"mean speed {mean:.3f} m/s over {t0:g}-{t1:g} s"

    return Check(f"mean speed {target_mps:g} +-{tol_mps:g} m/s over {t0:g}-{t1:g} s", fn)


def stays_on_feet(after_s: float) -> Check:
    """From ``after_s``: nothing but the feet touches the ground and the controller never leaves its feet
    (no RECOVERY_STAND or PASSIVE in the heartbeat)."""
    def fn(run: RunData):
        down = run.window("body_on_ground", after_s)
        t, m = run.heartbeat["t"], run.heartbeat["Mode"]
        left = sorted({Mode(int(x)).name for x in m[t >= after_s]} - {"BALANCE_STAND", "LOCOMOTION"})
        ok = len(down) and not np.any(down) and not left
        return ok, f"body touched the ground: {bool(np.any(down))}; other modes: {left or 'none'}"

    return Check(f"stays on its feet from {after_s:g} s", fn)


def moved_by_push(t_push: float, min_mps: float = 0.1) -> Check:
    def fn(run: RunData):
        speed = max_abs(np.hypot(run.window("vx", t_push, t_push + 1.0), run.window("vy", t_push, t_push + 1.0)))
        return speed >= min_mps, f"peak body speed {speed:.2f} m/s in the second after the push"

    return Check("the push moved it", fn)


def stays_in_place(limit_m: float, t0: float) -> Check:
    def fn(run: RunData):
        x, y = run.window("x", t0), run.window("y", t0)
        drift = float(np.max(np.hypot(x - x[0], y - y[0]))) if len(x) else math.nan
        return drift < limit_m, f"drift {drift * 100:.1f} cm from {t0:g} s (limit {limit_m * 100:g})"

    return Check(f"turns in place (drift < {limit_m * 100:g} cm)", fn)


# -- scenarios -------------------------------------------------------------------------------------
def stand_up_scenario() -> Scenario:
    request = 0.2
    return quad_scenario(
        "quad-stand-up", "lying folded, motors off; the operator asks for the stand: up to 0.21 m", 5.0, lying,
        timeline=(stand_request(request),),
        checks=(mode_reached(Mode.STAND_UP), settles_at_height(HEIGHT_M, request, 3.0), tilt_below(15 * DEG),
                upright_at_end()))


BALANCE_HOLD_S = 1.5  # s each set point is held; judged over its last 0.5 s
SET_POINTS = (("roll", "Roll", 10 * DEG), ("roll", "Roll", -10 * DEG), ("pitch", "Pitch", 10 * DEG),
              ("pitch", "Pitch", -10 * DEG), ("yaw", "Yaw", 10 * DEG), ("yaw", "Yaw", -10 * DEG),
              ("z", "Height", HEIGHT_M + 0.03), ("z", "Height", HEIGHT_M - 0.03))


def yaw_held(target_rad: float, t_ref: float, t0: float, t1: float, tol_rad: float = 1 * DEG) -> Check:
    """Yaw relative to its value at ``t_ref`` (the heading held when the stand began) within tolerance."""
    def fn(run: RunData):
        yaw = np.unwrap(run.state["yaw"])
        ref = float(np.interp(t_ref, run.state["t"], yaw))
        t = run.state["t"]
        err = yaw[(t >= t0) & (t < t1)] - ref - target_rad
        worst = max_abs(err, f"yaw {t0:g}-{t1:g} s")
        return worst < tol_rad, f"yaw worst error {worst / DEG:.2f} deg at {target_rad / DEG:+.0f} deg over {t0:g}-{t1:g} s"

    return Check(f"yaw holds {target_rad / DEG:+.0f} deg over {t0:g}-{t1:g} s", fn)


def balance_stand_scenario() -> Scenario:
    timeline, checks = [stand_request()], []
    neutral = {"Roll": 0.0, "Pitch": 0.0, "Yaw": 0.0, "Height": HEIGHT_M}
    for k, (field, signal, value) in enumerate(SET_POINTS):
        t = STAND_S + k * BALANCE_HOLD_S
        timeline.append(remote(t, **{**neutral, signal: value}))
        t0, t1 = t + BALANCE_HOLD_S - 0.5, t + BALANCE_HOLD_S
        if field == "yaw":
            checks.append(yaw_held(value, STAND_S - 0.1, t0, t1))
        elif field == "z":
            checks.append(tracks("z", value, t0, t1, 0.005, unit="mm", scale=1000.0))
        else:
            checks.append(tracks(field, value, t0, t1, 1 * DEG))
    end = STAND_S + len(SET_POINTS) * BALANCE_HOLD_S
    timeline.append(remote(end, **neutral))
    return quad_scenario(
        "quad-balance-stand", "standing: roll, pitch, yaw +-10 deg and height +-3 cm from the remote, each held",
        end + 1.5, standing, timeline, (*checks, upright_at_end()))


def push_scenario(force_n: float = 60.0, duration_s: float = 0.1) -> Scenario:
    t_push = STAND_S + 0.5
    return quad_scenario(
        "quad-push", f"balance stand; a sudden {force_n * duration_s:g} N s push from the left side "
                     f"({force_n:g} N for {duration_s:g} s) at the CoM", t_push + 3.0, standing,
        timeline=(stand_request(), *push(t_push, (0.0, -force_n, 0.0), duration_s)),
        checks=(moved_by_push(t_push), stays_on_feet(STAND_S), upright_at_end()))


def trot_scenario(speed_mps: float = 0.5, run_s: float = 4.0) -> Scenario:
    t_walk, t_go = STAND_S, STAND_S + 0.5
    t_stop = t_go + run_s
    return quad_scenario(
        "quad-trot", f"balance stand, trot on the spot, {speed_mps:g} m/s forward for {run_s:g} s, stop, stand",
        t_stop + 2.5, standing,
        timeline=(stand_request(), remote(t_walk, Mode=int(Mode.LOCOMOTION)), remote(t_go, VelX=speed_mps),
                  remote(t_stop, VelX=0.0), remote(t_stop + 1.0, Mode=int(Mode.BALANCE_STAND))),
        checks=(mode_reached(Mode.LOCOMOTION), mean_speed(speed_mps, t_go + 1.0, t_stop),
                tilt_below(10 * DEG, t_walk), upright_at_end(0.5)))


def turn_scenario(angle_rad: float = math.pi / 2, rate_rad_s: float = 0.5) -> Scenario:
    t_walk, t_go = STAND_S, STAND_S + 0.5
    t_stop = t_go + angle_rad / rate_rad_s
    return quad_scenario(
        "quad-turn", f"balance stand, trot in place turning {math.degrees(angle_rad):g} deg at "
                     f"{rate_rad_s:g} rad/s, stop, stand", t_stop + 2.5, standing,
        timeline=(stand_request(), remote(t_walk, Mode=int(Mode.LOCOMOTION)), remote(t_go, YawRate=rate_rad_s),
                  remote(t_stop, YawRate=0.0), remote(t_stop + 1.0, Mode=int(Mode.BALANCE_STAND))),
        checks=(yaw_reaches(angle_rad, 5 * DEG, t_stop + 1.0), stays_in_place(0.15, t_walk),
                tilt_below(10 * DEG, t_walk), upright_at_end(0.5)))


def recovery_scenario() -> Scenario:
    return quad_scenario(
        "quad-recovery", "toppled on its left side, motors off; the operator asks for the stand: "
                         "recovery stand (fold, roll over), stand up", 12.0, on_its_side,
        timeline=(stand_request(0.2),),
        checks=(mode_reached(Mode.RECOVERY_STAND), mode_reached(Mode.BALANCE_STAND, 0.2), upright_at_end()))


SCENARIOS = (stand_up_scenario(), balance_stand_scenario(), push_scenario(), trot_scenario(), turn_scenario(),
             recovery_scenario())
