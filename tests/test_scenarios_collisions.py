"""The collision scenarios (push, impact, wall), run in the rig and judged from their traces."""
import numpy as np
import pytest

from tools.limits import run_checks
from wheelleg.hil.run.scenario import RunData
from wheelleg.hil.scenarios import collisions
from wheelleg.hil.scenarios.collisions import FALLEN, falls_safely, recovers

from sharing import each_run, same_run

COLLISIONS = ("push", "impact", "wall")


@pytest.mark.parametrize("name", each_run(COLLISIONS))
def test_scenario_passes_its_checks(name, rig_run):
    rig_run(name).assert_passed()


@same_run("push")
def test_push_events_carry_the_impulse(rig_run):
    pushes = rig_run("push").events_of("push")
    assert len(pushes) == 4  # sudden and steady, front and side
    assert [round(p["impulse_ns"], 6) for p in pushes] == [5.0] * 4


@pytest.mark.slow
def test_a_wall_hit_too_fast_falls_safely(tmp_path):
    """At 0.5 m/s the robot cannot stop at the wall: it must fall safely (torque off), not recover."""
    results = {r.name: r for r in run_checks(collisions.wall_scenario(speed_mps=0.5), tmp_path)}
    assert results["falls safely: no torque after FALLEN"].passed, results
    assert "fell at" in results["falls safely: no torque after FALLEN"].detail
    assert not results["recovers: upright and at rest at the end"].passed


def _run(modes, torque_after_fall: float) -> RunData:
    """A synthetic run: heartbeat modes at 0.1 s steps, one hip torque command per step."""
    t = np.arange(len(modes)) * 0.1
    n = len(t)
    fell = np.argmax(np.array(modes) == FALLEN) if FALLEN in modes else n
    tau = np.where(np.arange(n) > fell, torque_after_fall, 1.0)
    state = {k: np.zeros(n) for k in ("pitch", "roll", "vx", "vy", "x", "y")}
    state["t"] = t
    return RunData(state=state, heartbeat={"t": t, "Mode": np.array(modes)},
                   hip_torque={1: (t, tau)}, wheel_current={1: (t, np.zeros(n))})


def test_falls_safely_catches_a_torque_after_the_fall():
    assert falls_safely()(_run([3, 3, FALLEN, FALLEN, FALLEN], 0.0)).passed
    spiked = falls_safely()(_run([3, 3, FALLEN, FALLEN, FALLEN], 2.0))
    assert not spiked.passed and "2.000 N m" in spiked.detail


def test_recovers_fails_on_a_fall_and_on_motion():
    assert not recovers()(_run([3, FALLEN, FALLEN], 0.0)).passed
    moving = _run([3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3], 0.0)
    assert recovers()(moving).passed
    moving.state["vx"][:] = 0.5
    assert not recovers()(moving).passed


def test_factories_refuse_nonsense_sizes():
    for make in (lambda: collisions.push_scenario(0.0), lambda: collisions.impact_scenario(-1.0),
                 lambda: collisions.wall_scenario(speed_mps=0.0)):
        with pytest.raises(ValueError):
            make()
