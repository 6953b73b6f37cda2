"""The quadruped's scenarios (hil/scenarios/quadruped*.py), run in the rig and judged from their traces.

The runs go through the pytest plugin's ``rig_run`` with qualified names
(``quadruped/NAME``), so they also show that a second robot runs through the
same rig, commands and plugin as the first. Every scenario passes.
"""
from __future__ import annotations

import numpy as np
import pytest

from wheelleg.controller.quadruped.modes import Mode
from wheelleg.hil import scenarios
from wheelleg.hil.analyze.replay import replay
from wheelleg.hil.record.sources import open_recording

from sharing import each_run, same_run

PASSING = ("quad-stand-up", "quad-balance-stand", "quad-push", "quad-trot", "quad-turn", "quad-recovery",
           "quad-estop", "quad-offline-joint")


def test_every_quadruped_scenario_is_judged_here():
    assert set(scenarios.all_scenarios("quadruped")) == set(PASSING)
    assert scenarios.get("quad-trot") is scenarios.get("quadruped/quad-trot")  # a unique bare name is found


@pytest.mark.parametrize("name", each_run(PASSING))
def test_scenario_passes_its_checks(rig_run, name):
    run = rig_run(f"quadruped/{name}")
    run.assert_passed()
    assert run.meta["robot"] == "quadruped" and run.meta["control_period_s"] == "0.004"


@same_run("quad-stand-up")
def test_stand_up_rises_from_lying_folded_within_3_s(rig_run):
    run = rig_run("quadruped/quad-stand-up")
    z = run.state["z"]
    assert z[0] < 0.08 and abs(z[-1] - 0.21) < 0.01  # from lying to the stand
    assert run.heartbeat["Mode"][0] == int(Mode.PASSIVE) and run.heartbeat["Mode"][-1] == int(Mode.BALANCE_STAND)
    assert max(np.abs(run.state["roll"]).max(), np.abs(run.state["pitch"]).max()) < np.radians(15)


@same_run("quad-offline-joint")
def test_a_quadruped_trace_and_its_log_replay_identically(rig_run):
    run = rig_run("quadruped/quad-offline-joint")
    for path in (run.trace_path, run.log_path):
        result = replay(path, robot="quadruped")
        assert result.identical, result.first.describe()
        assert result.ticks == run.ticks and result.source.robot == "quadruped"


@same_run("quad-stand-up")
def test_a_quadruped_log_is_told_apart_by_its_motor_ids(rig_run):
    """A candump log names no buses: the interface with motors 1..6 (and the remote) is bus 0."""
    run = rig_run("quadruped/quad-stand-up")
    source = open_recording(run.log_path, robot="quadruped")
    assert source.channels == {"can1": "vcan0", "can2": "vcan1"}
    with pytest.raises(Exception, match="not of the wheel-legged robot"):
        open_recording(run.trace_path, robot="wheel-legged")


@same_run("quad-offline-joint")
def test_inspect_names_the_quadrupeds_modes_and_offline_legs(rig_run):
    from wheelleg.hil.analyze.inspect_trace import summarize

    run = rig_run("quadruped/quad-offline-joint")
    lines = [f.text for f in summarize(run.trace_path).faults if f.kind == "heartbeat"]
    assert any("mode BALANCE_STAND" in line for line in lines)
    assert lines[-1].startswith("mode PASSIVE") and "offline RL motors" in lines[-1]
