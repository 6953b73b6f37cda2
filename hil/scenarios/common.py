"""Building blocks the scenario modules share: actions and checks."""
from __future__ import annotations

import math

import numpy as np

from wheelleg.hil.run.scenario import Action, Check, NotJudged, RunData

DEG = math.pi / 180


# -- actions -------------------------------------------------------------------
def remote(t_s: float, **signals) -> Action:
    """The operator changes what the remote sends (rig.dbc Operator signals)."""

    def fn(rig):
        rig.plant.remote.set(**signals)
        return dict(signals)

    return Action(t_s, "operator", fn)


def stand(t_s: float = 0.0, leg_length: float = 0.17) -> Action:
    return remote(t_s, Mode=1, LegLength=leg_length)


def push(t_s: float, force_n, duration_s: float, point=(0.0, 0.0, 0.0)) -> list:
    """A force on the body (world frame, N) held for ``duration_s``."""
    force = np.asarray(force_n, dtype=float)

    def on(rig):
        rig.physics.apply_body_force(force, point)
        return {"force_n": force.tolist(), "duration_s": duration_s, "impulse_ns": float(np.linalg.norm(force) * duration_s)}

    def off(rig):
        rig.physics.apply_body_force(np.zeros(3), point)
        return {}

    return [Action(t_s, "push", on), Action(t_s + duration_s, "push_end", off)]


# -- checks --------------------------------------------------------------------
def max_abs(values, what: str = "the check's window") -> float:
    """Largest |value| of ``values`` (n,); ``NotJudged`` when empty."""
    if not len(values):
        raise NotJudged(f"no samples in {what}")
    return float(np.max(np.abs(values)))


def pitch_below(limit_rad: float, after_s: float, until_s: float = np.inf) -> Check:
    def fn(run: RunData):
        worst = max_abs(run.window("pitch", after_s, until_s), f"pitch after {after_s:g} s")
        return worst < limit_rad, f"max |pitch| {worst / DEG:.2f} deg after {after_s:g} s (limit {limit_rad / DEG:g})"

    return Check(f"|pitch| < {limit_rad / DEG:g} deg after {after_s:g} s", fn)


def pitch_steady(wobble_rad: float, lean_rad: float, after_s: float) -> Check:
    """After ``after_s``: |pitch - its median| < ``wobble_rad`` (the balance) and |median| <
    ``lean_rad`` (upright). Apart because a body standing still leans as its IMU is
    mounted: a 3 deg mounting tilt leaves it 3 deg off whatever the controller does
    (nothing on the robot measures the mount), while a wobble is the controller's."""
    def fn(run: RunData):
        pitch = run.window("pitch", after_s, np.inf)
        lean = float(np.median(pitch)) if len(pitch) else 0.0
        wobble = max_abs(pitch - lean, f"pitch after {after_s:g} s")
        ok = wobble < wobble_rad and abs(lean) < lean_rad
        return ok, (f"pitch {lean / DEG:.2f} deg +- {wobble / DEG:.2f} after {after_s:g} s "
                    f"(limits {lean_rad / DEG:g} and +-{wobble_rad / DEG:g})")

    return Check(f"pitch steady within {wobble_rad / DEG:g} deg of a lean < {lean_rad / DEG:g} deg "
                 f"after {after_s:g} s", fn)


def drift_below(limit_m: float) -> Check:
    def fn(run: RunData):
        x, y = run.state["x"], run.state["y"]
        drift = float(np.max(np.hypot(x - x[0], y - y[0])))
        return drift < limit_m, f"max drift {drift * 100:.1f} cm (limit {limit_m * 100:g})"

    return Check(f"drift < {limit_m * 100:g} cm", fn)


def never_tips(limit_rad: float) -> Check:
    def fn(run: RunData):
        worst = max_abs(run.state["pitch"])
        return worst < limit_rad, f"max |pitch| {worst / DEG:.1f} deg (limit {limit_rad / DEG:g})"

    return Check(f"never tips past {limit_rad / DEG:g} deg", fn)


def first_mode(run: RunData, mode: int, after_s: float = 0.0) -> float | None:
    """Time (s) of the first heartbeat in ``mode`` at or after ``after_s``, or None."""
    t, m = run.heartbeat["t"], run.heartbeat["Mode"]
    hits = t[(m == mode) & (t >= after_s)]
    return float(hits[0]) if len(hits) else None


def tracks(field: str, target: float, t0: float, t1: float, tol: float, unit: str = "deg",
           scale: float = 1 / DEG, level: tuple[float, float] | None = None) -> Check:
    """Mean of a /sim/state field over [t0, t1) within tol of target; also its spread.

    With ``level`` (s, s): the field's change from its mean over that window, where the
    robot was asked for zero (an attitude judged apart from the IMU's mount, as
    ``pitch_steady`` does: nothing on a wheel-legged robot measures the mount's pitch, so a
    pose asked of it is a pose from where it believes level is; ``level_within`` judges
    that level apart).
    """

    def fn(run: RunData):
        values = run.window(field, t0, t1)
        offset = float(np.mean(run.window(field, *level))) if level else 0.0
        change = values - offset
        mean, worst = float(np.mean(change)), float(np.max(np.abs(change - target)))
        what = f"{field} {mean * scale:.2f} {unit}"
        if level:
            what += f" from its level ({offset * scale:.2f} at {level[0]:g}-{level[1]:g} s)"
        return worst < tol, (f"{what} (target {target * scale:.2f}), "
                             f"worst error {worst * scale:.2f} over {t0:g}-{t1:g} s (limit {tol * scale:g})")

    name = f"{field} holds {target * scale:.1f} {unit} over {t0:g}-{t1:g} s"
    return Check(name + (f" from its level at {level[0]:g}-{level[1]:g} s" if level else ""), fn)


def level_within(field: str, t0: float, t1: float, tol: float) -> Check:
    """Mean |field| (rad) over [t0, t1), where the robot is asked to stand level, below ``tol``."""

    def fn(run: RunData):
        mean = float(np.mean(run.window(field, t0, t1)))
        return abs(mean) < tol, f"{field} {mean / DEG:.2f} deg over {t0:g}-{t1:g} s (limit {tol / DEG:g})"

    return Check(f"level: |{field}| < {tol / DEG:g} deg over {t0:g}-{t1:g} s", fn)


def no_deadline_miss() -> Check:
    """One tick each period: from the heartbeats (lockstep) or the loop's tick log (in-process real
    time); for a program the rig cannot see tick (another process in real time), from its
    commands' timing on the bus (``judged_on_the_bus``)."""
    def fn(run: RunData):
        if judged_on_the_bus(run):
            return bus_command_timing(run)
        misses = len(run.events_of("deadline_miss"))
        return misses == 0, f"{misses} deadline misses"

    return Check("no controller deadline miss", fn)


def judged_on_the_bus(run: RunData) -> bool:
    """The program's ticks are seen only as its frames on the bus (the trace's program record)."""
    return run.program.get("judged_by") == "bus"


def bus_command_timing(run: RunData) -> tuple[bool, str]:
    """(passed, detail) of the program's command timing on each bus (``loop_timing.bus_timing`` of
    ``RunData.command_times``): commands on every bus, and no whole period without them."""
    from wheelleg.hil.run.loop_timing import bus_timing, describe_bus  # noqa: PLC0415

    period = float(run.meta.get("control_period_s", "nan"))
    end = float(run.state["t"][-1]) if len(run.state.get("t", ())) else float(run.meta.get("duration_s", "nan"))
    if not run.command_times:
        return False, "judged from the bus: no frames of the program recorded"
    ok, lines = True, []
    for bus, times in sorted(run.command_times.items()):
        timing = bus_timing(times, period, end, run.command_queued.get(bus))
        ok = ok and timing["ticks"] >= 2 and timing["missed_deadlines"] == 0
        lines.append(describe_bus(bus, timing))
    return ok, "its commands on the bus: " + "; ".join(lines)


TORQUE_OFF_NM = 0.05  # N m, |hip torque| that counts as "off" (CyberGear 16-bit step 0.0004)
CURRENT_OFF_A = 0.05  # A, |wheel current| that counts as "off"


def torque_after(run: RunData, t0: float, t1: float = np.inf) -> tuple[float, float]:
    """Largest |hip torque| (N m) and |wheel current| (A) commanded in [t0, t1) s."""
    hip = max((float(np.max(np.abs(tau[(t >= t0) & (t < t1)]), initial=0.0))
               for t, tau in run.hip_torque.values()), default=0.0)
    wheel = max((float(np.max(np.abs(i[(t >= t0) & (t < t1)]), initial=0.0))
                 for t, i in run.wheel_current.values()), default=0.0)
    return hip, wheel
