"""Robots as plug-ins (hil/robots/): the registry, scenario names by robot, the commands that take --robot.

A stand-in robot registered for one test (``FAKE``: the wheel-legged robot's
description with another name and controller program) shows that the table
is all a robot needs to be reachable from the commands.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys

import pytest

from wheelleg.dbc import CAN1, CAN2
from wheelleg.hil import cli, robots, scenarios
from wheelleg.hil.commands import list as list_command
from wheelleg.hil.record.run_metadata import rerun_command, run_record
from wheelleg.hil.run.scenario import Scenario

CALLS: list = []  # the stand-in controller program's calls: (robot period default, args.period)


def main(args: argparse.Namespace) -> int:
    """The stand-in robot's controller program (``controller_program`` points here)."""
    CALLS.append(args.period)
    return 0


@pytest.fixture
def fake_robot(monkeypatch):
    """A second robot registered: the default one's description under another name, period and
    program, without scenarios."""
    fake = dataclasses.replace(robots.get(), name="fake", control_period_s=0.004, controller_program=__name__,
                               scenario_modules=())
    robots.reset()
    monkeypatch.setitem(robots.entries(), "fake", robots.Entry("fake", f"{__name__}:FAKE", "tests", "0"))
    monkeypatch.setattr(sys.modules[__name__], "FAKE", fake, raising=False)
    yield fake
    robots.reset()


def test_the_default_robot_comes_first_and_an_unknown_one_is_a_one_line_error():
    assert robots.names()[0] == robots.DEFAULT == "wheel-legged"
    assert robots.get() is robots.get("wheel-legged")
    with pytest.raises(KeyError, match="no robot 'hexapod'; known: wheel-legged"):
        robots.get("hexapod")


@pytest.mark.parametrize("name", robots.names())
def test_every_robot_has_two_buses_its_databases_and_its_own_scenarios(name):
    robot = robots.get(name)
    assert robot.roles == (CAN1, CAN2)
    dbs = robot.databases()
    assert {m.name for m in dbs[CAN1].messages} >= {"SYNC", "Heartbeat", "IMU_Orientation"}
    ids = [d.can_id for bus in robot.buses for d in bus.devices if d.kind == "cybergear"]
    assert len(ids) == len(set(ids)) > 0  # CyberGear ids are unique across a robot's buses
    assert robot.model_files() and all(p.suffix == ".xml" for p in robot.model_files())
    table = scenarios.all_scenarios(name)
    assert table and all(s.robot == name for s in table.values())


def test_a_scenario_module_of_another_robot_is_refused(monkeypatch, fake_robot):
    foreign = Scenario("x", "a scenario of the default robot", 1.0, start=lambda physics: None)
    monkeypatch.setattr(sys.modules[__name__], "SCENARIOS", (foreign,), raising=False)
    monkeypatch.setattr(sys.modules[__name__], "FAKE", dataclasses.replace(fake_robot, scenario_modules=(__name__,)))
    robots.reset()
    monkeypatch.setitem(robots.entries(), "fake", robots.Entry("fake", f"{__name__}:FAKE", "tests", "0"))
    with pytest.raises(ValueError, match="runs on 'wheel-legged', not on 'fake'"):
        scenarios.all_scenarios("fake")


def test_scenario_names_bare_qualified_or_with_a_robot():
    balance = scenarios.get("balance")
    assert scenarios.get("wheel-legged/balance") is balance
    assert scenarios.get("balance", robot="wheel-legged") is balance
    assert scenarios.qualified_name(balance) == "balance"
    with pytest.raises(KeyError, match="names robot 'wheel-legged', but --robot is 'quadruped'"):
        scenarios.get("wheel-legged/balance", robot="quadruped")
    with pytest.raises(KeyError, match="no robot 'hexapod'"):
        scenarios.get("hexapod/balance")
    with pytest.raises(KeyError, match="no scenario 'nope'"):
        scenarios.get("nope")


def test_list_groups_the_scenarios_by_robot(capsys):
    assert list_command.run(argparse.Namespace(verbose=False, robot=None)) == 0
    lines = capsys.readouterr().out.splitlines()
    heads = [i for i, line in enumerate(lines) if not line.startswith("  ")]
    assert [lines[i].split(" ")[0] for i in heads] == list(robots.names())
    assert lines[0].startswith("wheel-legged (the default) from wheelleg-hil ")
    wheel = lines[heads[0] + 1:heads[1] if len(heads) > 1 else None]
    assert len(wheel) == len(scenarios.all_scenarios()) and wheel[0].split()[0] == "balance"


def test_controller_runs_the_robots_program_at_the_robots_period(fake_robot):
    CALLS.clear()
    args = cli.build_parser().parse_args(["controller", "--robot", "fake", "-i", "virtual"])
    assert args.func(args) == 0
    args = cli.build_parser().parse_args(["controller", "--robot", "fake", "--period", "0.01"])
    assert args.func(args) == 0
    assert CALLS == [0.004, 0.01]


def test_a_run_record_names_its_robot_and_the_rerun_command_qualifies_another_robots_scenario(fake_robot):
    channels = {CAN1: "vcan0", CAN2: "vcan1"}
    default = run_record(scenario="balance", seed=3, control_period_s=0.002, channels=channels)
    assert default["robot"] == "wheel-legged"
    assert rerun_command(default) == "wheelleg run balance --seed 3"
    other = run_record(scenario="balance", seed=3, control_period_s=0.004, channels=channels, robot="fake")
    assert other["robot"] == "fake"
    assert rerun_command(other) == "wheelleg run fake/balance --seed 3"


def test_a_plant_override_a_robot_does_not_model_is_refused(fake_robot):
    narrow = dataclasses.replace(fake_robot, plant_override_keys=frozenset({"com_x_m"}))
    narrow.check_overrides({"com_x_m": 0.01})
    with pytest.raises(ValueError, match="plant override wheel_kt_scale is not modelled for the fake robot"):
        narrow.check_overrides({"wheel_kt_scale": 1.1})


def test_a_campaign_names_another_robots_scenarios_qualified(tmp_path):
    from wheelleg.hil.campaign import execution, sampling
    from wheelleg.hil.commands import campaign

    args = cli.build_parser().parse_args(["campaign", "quad-push", "balance", "--samples", "1", "--vary",
                                          "com_x_m=-0.01..0.01", "--out", str(tmp_path)])
    spec = campaign.campaign_spec(args)
    assert spec["scenarios"] == ["quadruped/quad-push", "balance"]
    assert "wheelleg campaign quadruped/quad-push balance" in campaign.canonical_command(args)
    job = sampling.plan(spec["scenarios"], 1, 0, spec["ranges"])[0]
    settings = execution.RunSettings(tmp_path, None, False)
    row = execution.finish_files(execution.failed_row(job, "x"), job, settings)
    assert row["trace"] == "runs/quadruped/quad-push/sample-0000/quad-push.mcap"
    assert row["rerun"].startswith("wheelleg run quadruped/quad-push --seed ")
    bad = cli.build_parser().parse_args(["campaign", "quad-push", "--robot", "wheel-legged", "--out", str(tmp_path)])
    with pytest.raises(ValueError, match="no scenario 'quad-push' for the wheel-legged robot"):
        campaign.campaign_spec(bad)


def test_a_run_with_an_override_its_robots_plant_does_not_model_is_bad_input(tmp_path):
    from wheelleg.hil.commands.run import UsageError, execute

    args = cli.build_parser().parse_args(["run", "quadruped/quad-push", "--plant", "wheel_kt_scale=1.1",
                                          "--out", str(tmp_path), "--no-plot"])
    with pytest.raises(UsageError, match="wheel_kt_scale is not modelled for the quadruped robot"):
        execute(args)
    assert not list(tmp_path.iterdir())  # refused before anything was written
