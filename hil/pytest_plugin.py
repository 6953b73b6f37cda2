"""pytest plugin (entry point ``wheelleg``): rig options, fixtures and markers.

Installed with the package, so ``pip install wheelleg-hil`` is enough for a
robot team's own tests to use ``rig_run``::

    def test_balance_holds_pitch(rig_run):
        run = rig_run("balance", duration=2.0, seed=1)   # RigRun: a RunData + paths
        run.assert_passed()                                # the scenario's own checks
        assert abs(run.window("pitch", 1.0)).max() < 0.03  # arrays from the trace (s, rad)

- ``rig_run(scenario, duration=None, seed=0, plant=None, robot=None)`` runs the scenario
  (``"quadruped/quad-trot"`` or ``robot="quadruped"`` for another robot's) on
  the chosen transport (``--can-interface``, ``--can-channels``) and reads the
  trace back; ``plant`` is a dict of plant overrides (``wheelleg run --plant``,
  e.g. ``{"com_x_m": 0.02}``). Runs are cached for the session per (scenario,
  seed, duration, plant), so several tests can judge one run (under pytest-xdist, per
  worker: give such tests one ``xdist_group`` and ``--dist loadgroup``). Traces go to
  ``--rig-out`` (default: pytest's tmp).
- ``@pytest.mark.socketcan``: skipped, with the reason and the way to get
  vcan, when vcan0/vcan1 (or the ``--can-channels``) cannot be opened.
- A failing test that used ``rig_run`` gets a "wheelleg rig" report section
  naming the trace, the candump log and the commands to replay and inspect it.
  A run is registered with its test before it starts, so a test stopped during
  the run (pytest-timeout's signal method) still names the files the run
  was writing, and its traceback is one pytest can print (Python 3.11 gives some
  instructions no line number; a stop landing there crashed pytest's report).
  (pytest-timeout's thread method ends the process: no report.)

Importing this module must stay cheap (pytest loads it in every session of an
environment where the package is installed): the rig is imported on first use.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import re
import types
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from wheelleg.hil.record.run_metadata import rerun_command
from wheelleg.hil.run.scenario import RunData

_RUNS_OF_ITEM = pytest.StashKey[list]()  # RigRun, or PlannedRun while (or if) it has not returned
_SOCKETCAN_HELP = "needs real SocketCAN vcan0/vcan1 (skipped with the reason when they are absent)"


def pytest_addoption(parser):
    group = parser.getgroup("wheelleg", "wheelleg-hil rig")
    group.addoption("--can-interface", default="virtual",
                    help="python-can interface the rig runs on (virtual, socketcan, ...)")
    group.addoption("--can-channels", default="vcan0,vcan1",
                    help="CAN1 (wheels) and CAN2 (joints) channels, comma separated")
    group.addoption("--rig-out", default=None, metavar="DIR",
                    help="keep rig_run traces and logs in DIR (default: pytest's temporary directory)")


def pytest_configure(config):
    config.addinivalue_line("markers", f"socketcan: {_SOCKETCAN_HELP}")


def _channels(config) -> tuple[str, str]:
    names = tuple(n.strip() for n in str(config.getoption("--can-channels")).split(","))
    if len(names) != 2 or not all(names):
        raise pytest.UsageError(f"--can-channels {config.getoption('--can-channels')!r}: "
                                "need two names, CAN1 (wheels),CAN2 (joints)")
    return names


def socketcan_missing(channels: tuple[str, ...]) -> str | None:
    """Why socketcan on ``channels`` cannot be used here, or None."""
    try:
        from wheelleg.hil.bus import vcan
    except ImportError:
        vcan = None
    if vcan is not None and hasattr(vcan, "unavailable_reason"):
        return vcan.unavailable_reason(tuple(channels))
    missing = [c for c in channels if not Path("/sys/class/net", c).exists()]
    return f"no SocketCAN interface {', '.join(missing)} (run `wheelleg vcan up`)" if missing else None


def pytest_runtest_setup(item):
    if item.get_closest_marker("socketcan") is not None:
        reason = socketcan_missing(_channels(item.config))
        if reason:
            pytest.skip(f"socketcan test: {reason}")


# -- rig_run ---------------------------------------------------------------------------------
@dataclass
class RigRun(RunData):
    """A scenario run read back from its trace (``RunData``) plus where it lies and how it was judged."""

    trace_path: Path = Path()
    log_path: Path = Path()
    checks: list = field(default_factory=list)  # wheelleg.hil.run.scenario.CheckResult
    scenario: str = ""
    ticks: int = 0
    deadline_misses: int = 0

    @property
    def failed_checks(self) -> list:
        return [c for c in self.checks if not c.passed]

    @property
    def replay_command(self) -> str:
        return f"wheelleg replay {self.trace_path}"

    def describe(self) -> str:
        """The lines a bug report needs: what ran, where the files are, how to replay."""
        lines = [f"scenario {self.scenario} (seed {self.meta.get('seed', '?')}, {self.ticks} ticks, "
                 f"{self.deadline_misses} deadline misses)",
                 f"  trace:   {self.trace_path}",
                 f"  log:     {self.log_path}",
                 f"  replay:  {self.replay_command}",
                 f"  rerun:   {rerun_command(self.meta)}",
                 f"  inspect: wheelleg inspect {self.trace_path} --plot {self.trace_path.with_suffix('.inspect.png')}"]
        lines += [f"  [{c.mark}] {c.name}: {c.detail}" for c in self.checks]
        return "\n".join(lines)

    def assert_passed(self) -> None:
        """Fail with every failed check and the files when a scenario check did not pass."""
        if self.failed_checks:
            raise AssertionError(f"{len(self.failed_checks)} check(s) of {self.scenario} failed\n{self.describe()}")


@dataclass(frozen=True)
class PlannedRun:
    """A run about to start (or stopped before it returned): what it is and where it writes."""

    scenario: str
    seed: int
    duration: float | None
    overrides: tuple  # (plant key, value) pairs
    out_dir: Path
    trace_path: Path
    log_path: Path
    program: str = "python"  # ``wheelleg run --program``

    @property
    def key(self) -> tuple:
        return self.scenario, self.seed, self.duration, self.overrides, self.program

    def describe(self) -> str:
        """The files a run stopped midway leaves (written up to the stop) and how to run it again."""
        meta = {"scenario": self.scenario, "seed": self.seed, "duration_s": self.duration,
                "plant_overrides": json.dumps(dict(self.overrides))}
        return "\n".join([f"scenario {self.scenario} (seed {self.seed}) did not finish: the test stopped during the run",
                          f"  trace:   {self.trace_path} (as far as it got; a killed run's trace has no summary)",
                          f"  log:     {self.log_path}",
                          f"  rerun:   {rerun_command(meta)}"])


DIR_NAME_MAX = 120  # characters of a run's directory name (file systems allow 255 bytes)


def _dir_name(words: str) -> str:
    """A directory name for a run: its words made path-safe; past DIR_NAME_MAX (a
    campaign draw's dozen overrides) cut, with a digest of the whole to keep it unique."""
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", words)
    if len(name) <= DIR_NAME_MAX:
        return name
    digest = hashlib.sha1(words.encode()).hexdigest()[:12]
    return f"{name[:DIR_NAME_MAX - 13]}-{digest}"


class _RunCache:
    def __init__(self, out_dir: Path, interface: str, channels: tuple[str, str]):
        self.out_dir, self.interface, self.channels = out_dir, interface, channels
        self.runs: dict[tuple, RigRun] = {}
        self.executed = 0  # rig runs actually done (the rest came from the cache)

    def plan(self, scenario: str, duration: float | None, seed: int, plant: dict | None = None,
             robot: str | None = None, program: str = "python") -> PlannedRun:
        """The run ``get`` gives for these arguments, with the paths it writes (nothing runs).

        ``scenario`` is 'NAME' or 'ROBOT/NAME' (``robot`` says it too); the plan keeps
        the qualified name (``scenarios.qualified_name``), so one run is one cache entry.
        """
        from wheelleg.emulators.overrides import check_overrides  # ValueError: one line, the known keys
        from wheelleg.hil import scenarios  # the rig (MuJoCo, emulators) only when used
        from wheelleg.hil.run.rig import run_paths

        found = scenarios.get(scenario, robot)
        overrides = tuple(check_overrides(plant or {}).items())
        duration = None if duration is None else float(duration)
        name = scenarios.qualified_name(found)
        words = [f"{name}-seed{int(seed)}-{duration or 'full'}s", *(f"{k}={v!r}" for k, v in overrides)]
        if program != "python":
            words.append(f"program-{program}")
        out_dir = self.out_dir / _dir_name("-".join(words))
        return PlannedRun(name, int(seed), duration, overrides, out_dir, *run_paths(out_dir, found.name), program)

    def get(self, planned: PlannedRun) -> RigRun:
        run = self.runs.get(planned.key)
        if run is None:
            run = self.runs[planned.key] = self._execute(planned)
        return run

    def _execute(self, planned: PlannedRun) -> RigRun:
        if self.interface == "socketcan":
            reason = socketcan_missing(self.channels)
            if reason:
                pytest.skip(f"--can-interface socketcan: {reason}")
        from wheelleg.hil.commands.run import execute  # the rig (MuJoCo, emulators) only when used

        scenario, seed, duration = planned.scenario, planned.seed, planned.duration
        plant = [f"{k}={v!r}" for k, v in planned.overrides]
        args = argparse.Namespace(scenario=scenario, out=planned.out_dir, interface=self.interface,
                                  channel=list(self.channels),
                                  seed=seed, duration=duration, realtime=False, external_controller=False,
                                  no_plot=True, quiet=True, plant=plant, program=planned.program)
        outcome, results, data = execute(args)
        self.executed += 1
        return RigRun(**vars(data), trace_path=outcome.trace_path, log_path=outcome.log_path,
                      checks=list(results), scenario=scenario, ticks=outcome.ticks,
                      deadline_misses=outcome.deadline_misses)


@pytest.fixture(scope="session")
def rig_cache(request, tmp_path_factory) -> _RunCache:
    """The session's scenario runs, shared by every test (see ``rig_run``)."""
    config = request.config
    out = config.getoption("--rig-out")
    out_dir = Path(out) if out else tmp_path_factory.mktemp("wheelleg-rig")
    return _RunCache(out_dir, str(config.getoption("--can-interface")), _channels(config))


@pytest.fixture
def rig_run(request, rig_cache):
    """``rig_run(scenario, duration=None, seed=0, plant=None, robot=None, program="python") -> RigRun``: run
    (or reuse) a scenario run; ``scenario`` 'NAME' or 'ROBOT/NAME' (or ``robot=``) for a robot other than the
    default; ``program`` as ``wheelleg run --program`` takes it (python, firmware, PATH.so, a command)."""
    runs = request.node.stash.setdefault(_RUNS_OF_ITEM, [])

    def run(scenario: str, duration: float | None = None, seed: int = 0, plant: dict | None = None,
            robot: str | None = None, program: str = "python") -> RigRun:
        try:
            return _planned_and_run(scenario, duration, seed, plant, robot, program)
        except BaseException as exc:  # re-raised from here: this frame's entry is added again
            raise exc.with_traceback(_with_line_numbers(exc.__traceback__.tb_next))

    def _planned_and_run(scenario, duration, seed, plant, robot, program) -> RigRun:
        planned = rig_cache.plan(scenario, duration, seed, plant, robot, program)
        runs.append(planned)  # before the run: a test stopped during it still names the files
        result = rig_cache.get(planned)
        runs[:] = [r for r in runs if r is not planned]  # returned: the RigRun says more
        if not any(r is result for r in runs):  # identity: RunData holds arrays
            runs.append(result)
        return result
    return run


def _bug_report(run) -> str:
    """A run's lines in a failing test's report; a finished run's with a video of its failing moment."""
    if not isinstance(run, RigRun):
        return run.describe()
    from wheelleg.hil.watch.failure_video import bug_report_video  # noqa: PLC0415 (renders: only on failure)

    head, _, checks = run.describe().partition("\n  [")
    return f"{head}\n{bug_report_video(run.trace_path)}" + (f"\n  [{checks}" if checks else "")


def _with_line_numbers(tb: types.TracebackType | None) -> types.TracebackType | None:
    """The traceback with a line number in every entry.

    Python 3.11 leaves an entry's line number None where a signal lands on an
    instruction without one (the jump back at the end of a loop): pytest-timeout's
    signal method raises there, and pytest's report then crashes (INTERNALERROR)
    instead of showing the timed-out test. Such an entry gets its function's first line.
    """
    entries = []
    while tb is not None:
        entries.append(tb)
        tb = tb.tb_next
    rebuilt = None
    for entry in reversed(entries):
        line = entry.tb_lineno if entry.tb_lineno is not None else entry.tb_frame.f_code.co_firstlineno
        rebuilt = types.TracebackType(rebuilt, entry.tb_frame, entry.tb_lasti, line)
    return rebuilt


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    report = yield
    if report.failed and report.when == "call":
        runs = item.stash.get(_RUNS_OF_ITEM, [])
        if runs:
            report.sections.append(("wheelleg rig", "\n\n".join(_bug_report(r) for r in runs)))
    return report
