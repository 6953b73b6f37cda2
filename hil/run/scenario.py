"""What a scenario is: a start, a timeline of actions, and checks on the trace.

A scenario never touches the controller: it sets up the world, acts on it as
the outside world would (the remote, pushes, faults) and judges the run from
the recorded trace alone, so the same checks work on any trace.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class CheckResult:
    name: str
    passed: bool
    detail: str  # the measured figure against its bound, in words
    pace_bound: bool = True  # False: the verdict holds whether or not a real-time plant kept real time
    applies: bool = True  # False: the program gives it nothing to judge (``Check.needs_heartbeat``); not counted

    @property
    def mark(self) -> str:
        """PASS, FAIL, or N/A for a check that does not apply to the program that ran."""
        return "N/A" if not self.applies else "PASS" if self.passed else "FAIL"


class NotJudged(Exception):
    """A check found nothing to judge (its window holds no samples: the run was too short)."""


NOT_JUDGED = "not judged"  # the detail's first words when a check had nothing to judge


class NoHeartbeat(dict):
    """``RunData.heartbeat`` of a trace without one (a program on its own clock in another process sends
    none): reading a signal is ``NotJudged``, so a check that needs the heartbeat says why it cannot judge."""

    def __missing__(self, key):
        raise NotJudged(f"no heartbeat in the trace to read {key!r} from (a program judged on the bus sends none)")


@dataclass(frozen=True)
class Check:
    """A named judgement of a run: ``fn(run) -> (passed, detail)``. ``pace_bound`` False: what it judges
    does not depend on the plant's pace (a program's process that exited), so its failure is a failure
    even where a real-time plant could not keep real time (``wheelleg run``'s NOT REAL TIME)."""

    name: str
    fn: Callable
    pace_bound: bool = True
    # judges what the program reports in the rig's heartbeat (mode, offline mask, warning level):
    # for a program that sends none (one on its own clock, judged on the bus) it does not apply,
    # and says so (N/A) instead of failing "not judged" or passing on nothing
    needs_heartbeat: bool = False

    def __call__(self, run: "RunData") -> CheckResult:
        if self.needs_heartbeat and isinstance(run.heartbeat, NoHeartbeat):
            return CheckResult(self.name, True, "does not apply: the program sends no heartbeat to report in "
                               "(a program on its own clock, judged on the bus)", self.pace_bound, applies=False)
        try:
            passed, detail = self.fn(run)
        except NotJudged as exc:  # too short a run fails the check, saying why
            passed, detail = False, f"{NOT_JUDGED}: {exc} ({_run_length(run)})"
        except Exception as exc:  # a check that cannot compute has failed, loudly
            passed, detail = False, f"check raised {type(exc).__name__}: {exc}"
        if "nan" in detail.split():  # a NaN figure judges nothing; never print it as a measurement
            passed, detail = False, f"{NOT_JUDGED}: no samples to judge ({_run_length(run)})"
        return CheckResult(self.name, bool(passed), detail, self.pace_bound)


def in_window(t, values, t0: float, t1: float, what: str) -> np.ndarray:
    """``values`` (n,) at the times ``t`` (n,) s with t0 <= t < t1; ``NotJudged`` naming
    ``what`` when there is none (a check's window the run did not reach)."""
    inside = values[(t >= t0) & (t < t1)]
    if not len(inside):
        span = f"after {t0:g} s" if t1 == np.inf else f"over {t0:g}-{t1:g} s"
        raise NotJudged(f"no samples in {what} {span}")
    return inside


def _run_length(run) -> str:
    t = run.state.get("t", ())
    return f"the run ends at {float(t[-1]):.2f} s" if len(t) else "the run recorded no state"


@dataclass(frozen=True)
class Action:
    """Something the world does at ``t_s``: ``fn(rig) -> dict`` (the event's fields)."""

    t_s: float
    kind: str
    fn: Callable


@dataclass(frozen=True)
class Scenario:
    name: str
    summary: str
    duration_s: float
    start: Callable  # start(physics) -> None: the robot's initial pose
    timeline: tuple = ()  # Actions, any order
    checks: tuple = ()
    terrain: tuple = ()  # wheelleg.emulators.physics.TerrainFeature
    tags: tuple = ()
    robot: str = "wheel-legged"  # the registered robot it runs on (wheelleg.hil.robots)


@dataclass
class RunData:
    """A run read back from its trace, as arrays (seconds, SI units)."""

    state: dict  # /sim/state field -> (n,) array; "t" in s
    heartbeat: dict  # decoded Heartbeat (CAN1): "t", "Mode", "WarningLevel", ...
    hip_torque: dict  # CyberGear motor id -> (t (n,) s, torque feed-forward (n,) N m) commanded (type 1)
    wheel_current: dict  # esc id -> (t, current A) commanded
    events: list = field(default_factory=list)  # /scenario/events dicts with "t"
    meta: dict = field(default_factory=dict)
    bus_load: dict = field(default_factory=dict)  # "can1"/"can2" -> (window end t (n,) s, load (n,) s/s)
    joint_gains: dict = field(default_factory=dict)  # motor id -> (t (n,) s, Kp (n,) N m/rad, Kd (n,) N m s/rad)
    program: dict = field(default_factory=dict)  # the trace's ``program`` record (hil/program): kind, judged_by, ...
    command_times: dict = field(default_factory=dict)  # "can1"/"can2" -> (n,) s of the program's commands to its
    # most commanded device there (hil/record/rundata.py); read for programs other than the in-process Python one
    command_queued: dict = field(default_factory=dict)  # the same frames' (n,) s since the bus was busy before each
    # without a pause: the earliest the program can have sent it (``rundata.busy_since_ns``)
    program_load: dict = field(default_factory=dict)  # "can1"/"can2" -> peak share of a 100 ms window the program's
    # own frames held the bus (heartbeats aside); the same programs

    def window(self, key: str, t0: float, t1: float = np.inf) -> np.ndarray:
        """Values of a /sim/state field with t0 <= t < t1 (s), shape (n,); ``NotJudged`` when
        there is none (the run ended before ``t0``)."""
        return in_window(self.state["t"], self.state[key], t0, t1, key)

    def events_of(self, kind: str) -> list:
        return [e for e in self.events if e.get("kind") == kind]
