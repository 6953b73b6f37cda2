"""The trace's ``run`` metadata record: written by the rig, read by replay and the bug report.

Every key is a str -> str (MCAP metadata). ``REPLAY_KEYS`` are the ones a
trace needs to be replayed on another machine; ``run_record`` writes them
all (and a few more).
"""
from __future__ import annotations

import json
import shlex
import subprocess
from pathlib import Path

from wheelleg.dbc import CAN1, CAN2
from wheelleg.hil import robots

REPLAY_KEYS = ("scenario", "seed", "control_period_s", "git_revision", "controller_params", CAN1, CAN2)


def git_revision(cwd: Path | None = None) -> str:
    """The commit the code runs from ("unknown" outside a git checkout)."""
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=cwd or Path(__file__).parent, timeout=5)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def run_record(*, scenario: str, seed: int, control_period_s: float, channels: dict[str, str],
               physics_dt_s: float | None = None, duration_s: float | None = None,
               interface: str = "virtual", plant_overrides: dict[str, float] | None = None,
               robot: str | None = None) -> dict[str, str]:
    """The ``run`` record of one run; ``channels``: bus role -> interface name;
    ``plant_overrides``: the plant's per-run overrides (key -> SI value), JSON in the record;
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
                   "plant_overrides": json.dumps(plant_overrides or {}, sort_keys=True)})
    return record


def plant_overrides(run: dict) -> dict[str, float]:
    """The run's plant overrides (the record's ``plant_overrides``, JSON), {} when none or absent."""
    try:
        recorded = json.loads(run.get("plant_overrides") or "{}")
    except ValueError:
        return {}
    return {str(k): float(v) for k, v in recorded.items()} if isinstance(recorded, dict) else {}


def run_command(scenario: str, seed: int | str, duration_s: float | str | None = None,
                overrides: dict[str, float] | None = None, out: Path | str | None = None) -> str:
    """The one ``wheelleg run`` command (shell-quoted) that makes this run again, byte for byte."""
    words = ["wheelleg", "run", scenario, "--seed", str(seed)]
    if duration_s:
        words += ["--duration", str(duration_s)]
    for key, value in sorted((overrides or {}).items()):
        words += ["--plant", f"{key}={value!r}"]
    if out is not None:
        words += ["--out", str(out)]
    return shlex.join(words)


def rerun_command(run: dict) -> str:
    """``run_command`` of a recorded run (its ``run`` metadata record); another robot's
    scenario by its qualified name, ROBOT/NAME."""
    scenario, robot = run.get("scenario", "SCENARIO"), run.get("robot")
    if robot and robot != robots.DEFAULT:
        scenario = f"{robot}/{scenario}"
    return run_command(scenario, run.get("seed", 0), run.get("duration_s"), plant_overrides(run))
