"""The command line's edges: --version, one bus-flag convention, python-can's configuration,
bad input in one line with the documented exit status, a closed pipe, a progress line."""
import io
import os
import subprocess
import sys

import pytest

from wheelleg.hil.cli import main
from wheelleg.hil.run.progress import RunProgress
from wheelleg.hil.run.scenario import NOT_JUDGED, Check, RunData

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_version_prints_the_installed_version(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"wheelleg {version('wheelleg-hil')}"


def test_a_command_imports_its_own_module_only_and_a_wrong_name_still_lists_them_all():
    from wheelleg.hil.cli import SUBCOMMANDS, named_command

    assert named_command(["--version", "decode", "run"]) == "decode"
    assert named_command(["-h"]) is None and named_command(["nosuch", "run"]) is None
    code = ("import sys; from wheelleg.hil import cli; cli.build_parser('decode').parse_args(['decode', 'x.log']); "
            "print(sorted(m for m in ('mujoco', 'wheelleg.hil.run.rig', 'wheelleg.emulators.plant') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "[]", done.stderr
    proc = subprocess.run([sys.executable, "-m", "wheelleg.hil.cli", "nosuch"], capture_output=True, text=True,
                          cwd=REPO, timeout=120)
    assert proc.returncode == 2 and all(repr(name) in proc.stderr for name in SUBCOMMANDS)


@pytest.mark.parametrize("command", ["run", "controller"])
def test_run_and_controller_take_the_interface_from_canrc(tmp_path, monkeypatch, command):
    """No -i: python-can's ~/.canrc names the interface (an unknown one here, so the error shows it)."""
    (tmp_path / ".canrc").write_text("[default]\ninterface = wlnosuchiface\n")
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.delenv("CAN_INTERFACE", raising=False)
    argv = [command, "-c", "wlch8", "-c", "wlch9"]
    if command == "run":
        argv[1:1] = ["balance", "--out", str(tmp_path / "out"), "--no-plot"]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert "cannot open wlnosuchiface channel 'wlch8'" in str(exc.value.code)


def test_can_interface_outranks_canrc_and_the_flag_outranks_both(tmp_path, monkeypatch):
    from wheelleg.controller.bus_args import bus_choice
    from wheelleg.hil.cli import build_parser

    (tmp_path / ".canrc").write_text("[default]\ninterface = kvaser\nbitrate = 500000\n")
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("CAN_INTERFACE", "socketcan")
    parse = build_parser().parse_args
    choice = bus_choice(parse(["controller", "--joints", "can7"]), "virtual", ("a", "b"))
    assert (choice.interface, choice.channels, choice.kwargs) == ("socketcan", ("a", "can7"), {"bitrate": 500000})
    choice = bus_choice(parse(["run", "x", "-i", "virtual", "-c", "p", "-c", "q", "--bus-kwargs", "fd=True"]),
                        "socketcan", ("a", "b"))
    assert (choice.interface, choice.channels, choice.kwargs) == ("virtual", ("p", "q"), {"fd": True})


@pytest.mark.parametrize("argv, message", [
    (["run", "balance", "--duration", "-1"], "--duration: must be > 0 s, got -1"),
    (["run", "balance", "--out", "/proc/nope", "--no-plot"], "cannot write to /proc/nope"),
    (["run", "balance", "-c", "only-one"], "-c/--channel names the two buses"),
    (["run", "no-such-scenario"], "no-such-scenario"),
])
def test_bad_input_is_one_line_and_exit_2(argv, message):
    proc = subprocess.run([sys.executable, "-m", "wheelleg.hil.cli", *argv], capture_output=True, text=True,
                          cwd=REPO, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert message in proc.stderr.strip().splitlines()[-1]


def test_a_closed_pipe_is_no_traceback():
    read_end, write_end = os.pipe()
    os.close(read_end)  # `| head` that has already left
    try:
        proc = subprocess.run([sys.executable, "-m", "wheelleg.hil.cli", "list", "-v"], stdout=write_end,
                              stderr=subprocess.PIPE, text=True, cwd=REPO, timeout=120)
    finally:
        os.close(write_end)
    assert proc.returncode == 141
    assert proc.stderr == ""


def _run_data(t):
    import numpy as np
    return RunData(state={"t": np.asarray(t, float), "pitch": np.zeros(len(t))}, heartbeat={}, hip_torque={},
                   wheel_current={})


def test_a_check_with_an_empty_window_says_so_and_fails():
    from wheelleg.hil.scenarios.common import pitch_below

    result = pitch_below(0.1, after_s=1.0)(_run_data([0.0, 0.25, 0.5]))
    assert not result.passed
    assert result.detail == "not judged: no samples in pitch after 1 s (the run ends at 0.50 s)"
    assert "nan" not in result.detail
    assert pitch_below(0.1, after_s=0.2)(_run_data([0.0, 0.25, 0.5])).passed


def test_a_nan_figure_is_never_a_measurement():
    result = Check("x", lambda run: (True, "mean speed nan m/s"))(_run_data([0.0, 2.0]))
    assert (result.passed, result.detail) == (False, "not judged: no samples to judge (the run ends at 2.00 s)")


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_line_on_a_terminal_and_quiet_elsewhere():
    tty = _Terminal()
    progress = RunProgress("balance", 10.0, stream=tty)
    progress(2.5)
    assert "balance: 2.50/10 s simulated" in tty.getvalue()
    pipe, quiet = io.StringIO(), _Terminal()
    RunProgress("balance", 10.0, stream=pipe)(2.5)
    RunProgress("balance", 10.0, enabled=False, stream=quiet)(2.5)
    assert pipe.getvalue() == quiet.getvalue() == ""


@pytest.mark.parametrize(("robot", "short_run"), [("wheel-legged", "balance"), ("quadruped", "quadruped/quad-balance-stand")])
def test_every_check_on_a_run_too_short_for_it_says_not_judged_never_raises(rig_run, robot, short_run):
    """`wheelleg run NAME --duration S` shorter than a check's window, or ended before its
    fault: every scenario's checks, on a 0.2 s run, either judge it or say why they cannot."""
    from wheelleg.hil import scenarios

    run = rig_run(short_run, duration=0.2, seed=1)
    results = [check(run) for scenario in scenarios.all_scenarios(robot).values() for check in scenario.checks]
    assert len(results) > 20
    raised = [f"{r.name}: {r.detail}" for r in results if r.detail.startswith("check raised")]
    assert raised == []
    assert sum(r.detail.startswith(NOT_JUDGED) for r in results) > 10  # the windows after 0.2 s, the faults at 1 s
