"""The pytest plugin as a robot team uses it: rig_run, the socketcan marker, failure reports."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from wheelleg.hil.cli import main


def offscreen_gl_missing() -> str | None:
    import ctypes.util

    return None if ctypes.util.find_library("OSMesa") or ctypes.util.find_library("EGL") else "no libosmesa6"

pytest_plugins = ["pytester"]

SCENARIO_TESTS = '''
import numpy as np
from wheelleg.hil.run.scenario import RunData

SEEN = []

def test_run_hands_back_arrays(rig_run):
    run = rig_run("balance", duration=0.2, seed=1)
    SEEN.append(run)
    assert isinstance(run, RunData) and run.trace_path.is_file() and run.log_path.is_file()
    assert run.ticks == 100 and len(run.state["t"]) == 100
    assert run.meta["can1"] == "rigA" and run.meta["can2"] == "rigB" and run.meta["seed"] == "1"
    assert len(run.heartbeat["t"]) == 100 and np.all(np.diff(run.heartbeat["Tick"]) == 1)

def test_second_test_shares_the_run(rig_run, rig_cache):
    run = rig_run("balance", duration=0.2, seed=1)
    assert run is SEEN[0] and rig_cache.executed == 1

def test_a_failing_scenario_test(rig_run):
    run = rig_run("balance", duration=0.2, seed=1)
    assert run.deadline_misses < 0, "deliberately failing"

def test_plant_overrides_are_a_run_of_their_own(rig_run, rig_cache):
    import json
    plain = rig_run("balance", duration=0.2, seed=1)
    shifted = rig_run("balance", duration=0.2, seed=1, plant={"com_x_m": "0.02"})
    assert shifted is not plain and rig_run("balance", duration=0.2, seed=1, plant={"com_x_m": 0.02}) is shifted
    assert json.loads(shifted.meta["plant_overrides"]) == {"com_x_m": 0.02}
    assert json.loads(plain.meta["plant_overrides"]) == {}
    assert "rerun:   wheelleg run balance --seed 1 --duration 0.2 --plant com_x_m=0.02" in shifted.describe()
    assert rig_cache.executed == 2
'''


def test_rig_run_fixture_caches_runs_and_reports_failures(pytester):
    pytester.makepyfile(test_scenarios=SCENARIO_TESTS)
    out = pytester.path / "rig-out"
    result = pytester.runpytest("-p", "no:cacheprovider", "--can-channels", "rigA,rigB", "--rig-out", str(out))
    result.assert_outcomes(passed=3, failed=1)
    text = result.stdout.str()
    section = text[text.index("wheelleg rig"):]
    trace = re.search(r"trace:\s+(\S+\.mcap)", section).group(1)
    log = re.search(r"log:\s+(\S+\.log)", section).group(1)
    assert trace.startswith(str(out)) and f"wheelleg replay {trace}" in section
    assert f"wheelleg inspect {trace}" in section
    assert "rerun:   wheelleg run balance --seed 1 --duration 0.2" in section
    assert "[PASS]" in section or "[FAIL]" in section  # the scenario's own checks are listed
    if offscreen_gl_missing() is None:  # a video of the failing moment beside the trace
        video = re.search(r"video:\s+(\S+\.failure\.mp4) \(the failing moment", section).group(1)
        assert video == trace.removesuffix(".mcap") + ".failure.mp4" and Path(video).stat().st_size > 1000
    else:
        assert "video:   none" in section
    # the replay command the report names works on the trace and on the log
    assert main(["replay", trace]) == 0
    assert main(["replay", log]) == 0
    # passing tests get no rig section
    assert text.count("wheelleg rig") == 1


TIMEOUT_TEST = '''
import pytest
import wheelleg.hil.commands.run  # the rig's imports before the clock starts

@pytest.mark.timeout(1)
def test_stopped_during_a_long_run(rig_run):
    rig_run("balance", seed=3)  # the full scenario: many seconds
'''


@pytest.mark.slow
def test_a_test_timed_out_during_rig_run_names_the_trace(pytester):
    pytest.importorskip("pytest_timeout")
    pytester.makepyfile(test_timeout=TIMEOUT_TEST)
    out = pytester.path / "rig-out"
    # a subprocess: the signal method needs the main thread, and the thread method would end this process
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "--timeout-method", "signal",
                                           "--rig-out", str(out))
    result.assert_outcomes(failed=1)
    text = result.stdout.str()
    assert "Timeout" in text
    section = text[text.index("wheelleg rig"):]
    trace = re.search(r"trace:\s+(\S+)", section).group(1)
    log = re.search(r"log:\s+(\S+)", section).group(1)
    assert trace == str(out / "balance-seed3-fulls" / "balance.mcap")
    assert log == str(out / "balance-seed3-fulls" / "balance.log")
    assert "did not finish" in section and "rerun:   wheelleg run balance --seed 3" in section


# A stop that lands where Python 3.11 gives no line number: the jump back at the end of a
# loop whose body ends in an `if`. The handler fails the test only there, as pytest-timeout's
# signal method would if its alarm came at that instruction.
LINELESS_STOP_TEST = '''
import signal
import pytest


def spin():
    rows = [(1, 0)] * 1000
    while True:
        for a, b in rows:
            if a == 2 and b:
                return a


def stop(signum, frame):
    if frame.f_lineno is None:
        pytest.fail("Timeout at an instruction without a line number")


def test_stopped_without_a_line_number(rig_run, rig_cache, monkeypatch):
    monkeypatch.setattr(rig_cache, "get", lambda planned: spin())
    rig_cache.plan("balance", 0.1, 0)  # the rig's imports before the alarms start
    signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, 0.0001, 0.0001)
    try:
        rig_run("balance", duration=0.1)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
'''


def test_a_stop_without_a_line_number_is_reported_not_an_internal_error(pytester):
    pytester.makepyfile(test_lineless=LINELESS_STOP_TEST)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-p", "no:xdist")
    assert "INTERNALERROR" not in result.stdout.str() + result.stderr.str()
    result.assert_outcomes(failed=1)
    assert "Timeout at an instruction without a line number" in result.stdout.str()
    assert "did not finish" in result.stdout.str()


def test_socketcan_marker_and_transport_skip_with_a_reason(pytester):
    pytester.makepyfile(test_sc='''
import pytest

@pytest.mark.socketcan
def test_needs_vcan():
    raise AssertionError("must not run without vcan")

def test_rig_on_socketcan(rig_run):
    rig_run("balance", duration=0.1)
    raise AssertionError("must not run without vcan")
''')
    result = pytester.runpytest("-p", "no:cacheprovider", "-rs", "--can-interface", "socketcan",
                                "--can-channels", "novcan8,novcan9")
    result.assert_outcomes(skipped=2)
    text = result.stdout.str()
    assert "socketcan test: novcan8" in text and "--can-interface socketcan: novcan8" in text


def test_options_and_marker_are_registered(pytester):
    result = pytester.runpytest("--help")
    text = result.stdout.str()
    for option in ("--can-interface", "--can-channels", "--rig-out"):
        assert option in text
    markers = pytester.runpytest("--markers").stdout.str()
    assert "@pytest.mark.socketcan" in markers


def test_bad_channels_option_is_a_usage_error(pytester):
    pytester.makepyfile(test_x="def test_x(rig_run):\n    pass\n")
    result = pytester.runpytest("--can-channels", "onlyone")
    assert result.ret != 0
    assert "need two names" in result.stdout.str() + result.stderr.str()


@pytest.mark.parametrize("name", ["wheelleg.hil.pytest_plugin"])
def test_loading_the_plugin_does_not_import_the_rig(name):
    import subprocess
    import sys
    code = (f"import sys, {name}; bad = [m for m in ('mujoco', 'wheelleg.hil.run.rig', 'wheelleg.emulators') if m in sys.modules];"
            "print(bad); sys.exit(1 if bad else 0)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr


def test_a_run_with_a_dozen_overrides_gets_a_short_unique_directory():
    """A campaign draw's twelve overrides made a 260-character name (OSError: file name
    too long); cut names keep a digest of the whole, so two draws never share one."""
    from wheelleg.hil.pytest_plugin import DIR_NAME_MAX, _dir_name
    words = "push-seed1-fulls-" + "-".join(f"supply_voltage_{i}={0.123456789 * i!r}" for i in range(12))
    other = words.replace("voltage_11", "voltage_12")
    assert len(words) > 255
    assert len(_dir_name(words)) <= DIR_NAME_MAX
    assert _dir_name(words) != _dir_name(other)
    assert _dir_name("balance-seed0-fulls") == "balance-seed0-fulls"
