"""The trace's ``run`` metadata record: written by the rig, read by replay and the bug report.

Every key is a str -> str (MCAP metadata). ``REPLAY_KEYS`` are the ones a
trace needs to be replayed on another machine, or run again to the same
bytes; ``run_record`` writes them all (and a few more).
"""
from __future__ import annotations

import json
import shlex
import subprocess
from decimal import Decimal, InvalidOperation
from pathlib import Path

from wheelleg.dbc import CAN1, CAN2
from wheelleg.hil import robots

REPLAY_KEYS = ("scenario", "seed", "control_period_s", "git_revision", "controller_params", CAN1, CAN2,
               "epoch_s")
_NS_PER_S = 1_000_000_000


def git_revision(cwd: Path | None = None) -> str:
    """The commit the code runs from ("unknown" outside a git checkout)."""
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=cwd or Path(__file__).parent, timeout=5)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def parse_epoch(text: str) -> int:
    """``--epoch SECONDS`` (seconds since 1970, a decimal such as 1700000000.25) as integer ns.

    Read as a decimal, not a float, so that every digit given is kept; ValueError
    (one line) unless it is a number >= 0 with no more than 9 fraction digits.
    """
    try:
        value = Decimal(text.strip())
    except InvalidOperation:
        raise ValueError(f"epoch {text!r}: not a number of seconds") from None
    if not value.is_finite() or value < 0:
        raise ValueError(f"epoch {text!r}: must be >= 0 s (seconds since 1970)")
    ns = value * _NS_PER_S
    if ns != ns.to_integral_value():
        raise ValueError(f"epoch {text!r}: finer than a nanosecond")
    return int(ns)


def epoch_text(epoch_ns: int) -> str:
    """Integer ns as the shortest exact decimal of seconds (``parse_epoch`` reads it back)."""
    seconds, ns = divmod(epoch_ns, _NS_PER_S)
    return f"{seconds}.{ns:09d}".rstrip("0") if ns else str(seconds)


def run_record(*, scenario: str, seed: int, control_period_s: float, channels: dict[str, str],
               physics_dt_s: float | None = None, duration_s: float | None = None,
               interface: str = "virtual", plant_overrides: dict[str, float] | None = None,
               epoch_ns: int = 0, robot: str | None = None) -> dict[str, str]:
    """The ``run`` record of one run; ``channels``: bus role -> interface name;
    ``plant_overrides``: the plant's per-run overrides (key -> SI value), JSON in the record;
    ``epoch_ns``: what the candump log adds to every time (``epoch_s``; the trace keeps the run's time);
    ``robot``: the name of the registered robot it ran (None: the default)."""
    spec = robots.get(robot)
    record = {"scenario": scenario, "seed": str(seed), "control_period_s": repr(control_period_s),
              "robot": spec.name}
    if physics_dt_s is not None:
        record["physics_dt_s"] = repr(physics_dt_s)
    if duration_s is not None:
        record["duration_s"] = repr(duration_s)
    record.update({"interface": interface, CAN1: channels[CAN1], CAN2: channels[CAN2],
                   "git_revision": git_revision(),
                   "controller_params": spec.params_json(),
                   "plant_overrides": json.dumps(plant_overrides or {}, sort_keys=True),
                   "epoch_s": epoch_text(epoch_ns)})
    return record


def plant_overrides(run: dict) -> dict[str, float]:
    """The run's plant overrides (the record's ``plant_overrides``, JSON), {} when none or absent."""
    try:
        recorded = json.loads(run.get("plant_overrides") or "{}")
    except ValueError:
        return {}
    return {str(k): float(v) for k, v in recorded.items()} if isinstance(recorded, dict) else {}


def run_command(scenario: str, seed: int | str, duration_s: float | str | None = None,
                overrides: dict[str, float] | None = None, out: Path | str | None = None,
                epoch_ns: int = 0, program: str = "python") -> str:
    """The one ``wheelleg run`` command (shell-quoted) that makes this run again, byte for byte."""
    words = ["wheelleg", "run", scenario, "--seed", str(seed)]
    if program != "python":
        words += ["--program", program]
    if duration_s:
        words += ["--duration", str(duration_s)]
    if epoch_ns:
        words += ["--epoch", epoch_text(epoch_ns)]
    for key, value in sorted((overrides or {}).items()):
        words += ["--plant", f"{key}={value!r}"]
    if out is not None:
        words += ["--out", str(out)]
    return shlex.join(words)


def recorded_epoch(run: dict) -> int:
    """The run's ``epoch_s`` as ns; 0 when absent (older traces) or unreadable."""
    try:
        return parse_epoch(run.get("epoch_s") or "0")
    except ValueError:
        return 0


def rerun_command(run: dict) -> str:
    """``run_command`` of a recorded run (its ``run`` metadata record); another robot's
    scenario by its qualified name, ROBOT/NAME."""
    scenario, robot = run.get("scenario", "SCENARIO"), run.get("robot")
    if robot and robot != robots.DEFAULT:
        scenario = f"{robot}/{scenario}"
    return run_command(scenario, run.get("seed", 0), run.get("duration_s"), plant_overrides(run),
                       epoch_ns=recorded_epoch(run))
