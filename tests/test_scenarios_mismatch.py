"""The controller against a plant that is not the robot it believes in (model mismatch).

Each run changes the plant's truth (``rig_run(..., plant={...})``, ``wheelleg run
--plant``) while the controller keeps its constants. Before the balance trim (the
LQR's position-error integral) the CoM 3 cm forward made `balance` creep 210 cm in
10 s and the CoM 2 cm forward made `jump` fall; before the ESC watch took the last
two commands, 2 ms of feedback latency latched a false ESC fault in `drop`.
"""
import numpy as np
import pytest


def test_balance_with_the_com_3cm_forward_holds_its_spot(rig_run):
    run = rig_run("balance", plant={"com_x_m": 0.03})
    x, y = run.state["x"], run.state["y"]
    drift = np.hypot(x - x[0], y - y[0])
    late = run.state["t"] > run.state["t"][-1] - 3.0
    assert float(np.max(drift[late])) < 0.05, "no creep: back at its spot over the last 3 s"
    assert float(np.max(drift)) < 0.15, "the transient while the trim builds stays bounded"


def test_jump_with_the_com_2cm_forward_stays_upright(rig_run):
    rig_run("jump", plant={"com_x_m": 0.02}).assert_passed()


@pytest.mark.parametrize("plant", [{"feedback_delay_s": 0.002}])
def test_drop_with_late_feedback_raises_no_false_esc_fault(rig_run, plant):
    rig_run("drop", plant=plant).assert_passed()
