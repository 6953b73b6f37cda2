"""The basic scenarios, run in the rig and judged from their MCAP traces."""
import argparse
from pathlib import Path

import pytest

from wheelleg.hil.commands.run import execute

from sharing import each_run

pytestmark = pytest.mark.slow  # scenario runs: scheduled first (tests/conftest.py)

BASIC = ("balance", "stand-up", "drive", "turn", "height")


def run_scenario(name: str, out: Path, seed: int = 0, duration=None):
    args = argparse.Namespace(scenario=name, out=out, interface="virtual", channel=["vcan0", "vcan1"],
                              seed=seed, duration=duration, realtime=False, external_controller=False,
                              no_plot=True)
    outcome, results, _ = execute(args)
    return outcome, results


@pytest.mark.parametrize("name", each_run(BASIC))
def test_scenario_passes_its_checks(rig_run, name):
    """Through ``rig_run``: the runs other tests judge too (the firmware's drive) are made once."""
    run = rig_run(name)
    assert run.trace_path.exists() and run.log_path.exists()
    assert run.checks
    run.assert_passed()


def test_same_scenario_and_seed_give_byte_identical_logs(tmp_path):
    first, _ = run_scenario("drive", tmp_path / "a", seed=3, duration=2.5)
    second, _ = run_scenario("drive", tmp_path / "b", seed=3, duration=2.5)
    a, b = first.log_path.read_bytes(), second.log_path.read_bytes()
    assert len(a) > 100_000
    assert a == b


def test_a_different_seed_changes_the_log(tmp_path):
    """The seed reaches the run (IMU noise): without this the test above proves little."""
    first, _ = run_scenario("balance", tmp_path / "a", seed=1, duration=0.5)
    second, _ = run_scenario("balance", tmp_path / "b", seed=2, duration=0.5)
    assert first.log_path.read_bytes() != second.log_path.read_bytes()


def test_a_run_trace_carries_its_model_and_dbc_files(tmp_path):
    """The trace alone is the bug report: the MJCF and every DBC file ride along."""
    from wheelleg.dbc import all_dbc_files
    from wheelleg.hil.record.trace import TraceReader

    outcome, _ = run_scenario("balance", tmp_path, duration=0.1)
    names = set(TraceReader(outcome.trace_path).attachments)
    assert {"robot.xml", "scene.xml"} <= names
    assert {p.name for p in all_dbc_files()} <= names


def test_the_run_prints_its_start_up_and_the_factor_to_the_verdict(tmp_path, capsys):
    """The speed figures a user sees: start-up, and real time counted through the checks."""
    import argparse as _argparse
    from wheelleg.hil.commands.run import run

    args = _argparse.Namespace(scenario="balance", out=tmp_path, interface="virtual", channel=["vcan0", "vcan1"],
                               seed=0, duration=0.2, realtime=False, external_controller=False, no_plot=True,
                               quiet=True, plant=[])
    run(args)
    out = capsys.readouterr().out
    assert "start-up" in out and "(imports, model build)" in out
    assert "x real time from the first tick to the checks' verdict" in out


def test_controller_debug_has_a_described_schema_for_foxglove(tmp_path):
    """/controller/debug is wheelleg/msg/ControllerDebug (float64 each), every field described with its unit,
    and every message of a run validates against it (no key outside the table)."""
    import json

    import jsonschema
    from mcap.reader import make_reader
    from wheelleg.controller.telemetry import DEBUG_FIELDS
    from wheelleg.hil import robots
    from wheelleg.hil.record.trace import TraceReader

    outcome, _ = run_scenario("stand-up", tmp_path, duration=0.6)
    reader = TraceReader(outcome.trace_path)
    with open(outcome.trace_path, "rb") as f:
        summary = make_reader(f).get_summary()
    (schema_rec,) = [s for s in summary.schemas.values() if s.name == "wheelleg/msg/ControllerDebug"]
    (channel,) = [c for c in summary.channels.values() if c.topic == "/controller/debug"]
    assert json.loads(channel.metadata["wheelleg_fields"]) == list(DEBUG_FIELDS)  # the rig's names, in order
    lines = [line for line in schema_rec.data.decode().splitlines() if line.startswith("float64 ")]
    assert len(lines) == len(DEBUG_FIELDS) and all("(" in line.partition("#")[2] for line in lines)  # a unit in each
    schema = robots.get("wheel-legged").debug_schema  # what a record reads back as, as when it was JSON
    messages = reader.topic("/controller/debug")
    assert len(messages) > 100
    # one validator for all messages: jsonschema.validate checks the schema and builds a
    # validator per message (298 messages: 3.2 s against 0.05 s)
    validator = jsonschema.validators.validator_for(schema)
    validator.check_schema(schema)
    valid = validator(schema)
    for _, payload in messages:
        valid.validate(payload)


def test_a_later_command_in_the_same_process_counts_its_start_up_from_its_own_call(tmp_path, capsys, monkeypatch):
    """The first ``main`` counts the imports; a process that calls it again (a test session, a
    worker) an hour on does not print that hour as the next run's start-up."""
    import re
    from wheelleg.hil import cli

    monkeypatch.setattr(cli, "STARTED_S", cli.STARTED_S - 3600.0)  # as if imported an hour ago
    monkeypatch.setattr(cli, "_IMPORTS_COUNTED", True)  # and a command already ran
    cli.main(["run", "balance", "--duration", "0.1", "--no-plot", "--out", str(tmp_path)])
    start_up = float(re.search(r"start-up ([0-9.]+) s", capsys.readouterr().out).group(1))
    assert start_up < 600.0
