"""The controller against a plant that is not the robot it believes in (model mismatch).

Each run changes the plant's truth (``rig_run(..., plant={...})``, ``wheelleg run
--plant``) while the controller keeps its constants. Before the balance trim (the
LQR's position-error integral) the CoM 3 cm forward made `balance` creep 210 cm in
10 s; before the ESC watch took the last two commands, 2 ms of feedback latency
latched a false ESC fault in `drop`.

Before the wheels levelled the body in flight, `jump` with the CoM 2 cm forward
ended FALLEN: lifting the wheels at take-off pulls below and behind the CoM and the
body spun nose up about 1 rad before landing.

Not here because it does not hold yet: a drift under 5 cm with the CoM 3 cm forward
(the transient while the trim builds reaches 8.5 cm at 0.8 s; the test below asserts
no creep instead).
"""
import numpy as np
import pytest

from wheelleg.hil.scenarios.basic import forward_position


def test_balance_with_the_com_3cm_forward_holds_its_spot(rig_run):
    run = rig_run("balance", plant={"com_x_m": 0.03})
    x, y = run.state["x"], run.state["y"]
    drift = np.hypot(x - x[0], y - y[0])
    late = run.state["t"] > run.state["t"][-1] - 3.0
    assert float(np.max(drift[late])) < 0.05, "no creep: back at its spot over the last 3 s"
    assert float(np.max(drift)) < 0.15, "the transient while the trim builds stays bounded"


@pytest.mark.parametrize("com_x_m", [0.02, -0.02])
def test_jump_with_the_com_2cm_off_lands_upright(rig_run, com_x_m):
    rig_run("jump", plant={"com_x_m": com_x_m}).assert_passed()


def test_on_a_slippery_floor_the_slip_observer_keeps_the_spot(rig_run):
    """Friction 0.3: the sudden pushes spin the wheels. Without the slip observer the
    encoders' travel counted the spin and `push` ended 0.47 m from its start (limit 0.5);
    with it, 0.22 m."""
    run = rig_run("push", plant={"friction": 0.3})
    run.assert_passed()
    x, y = run.state["x"], run.state["y"]
    assert float(np.hypot(x[-1] - x[0], y[-1] - y[0])) < 0.35


def test_drive_with_a_heavy_body_and_the_com_2cm_forward_stops_short(rig_run):
    """Body 1.4x as heavy, its CoM 2 cm forward: the legs lean ~0.11 rad to hold it, that
    much nearer the thighs' stops, and braking forward leans them further. Before the
    speed set point asked the LQR for the lean of its deceleration, the LQR leaned the
    legs on its clamped travel share alone and the forward stop took STOP_BEFORE_M."""
    run = rig_run("drive", plant={"body_mass_scale": 1.4, "com_x_m": 0.02})
    run.assert_passed()
    t, x = run.state["t"], forward_position(run)
    at_stop = float(np.interp(4.0, t, x))  # the forward stop command
    assert float(np.max(x[t >= 4.0])) - at_stop < 0.4, "a stop with 0.1 m to spare"


@pytest.mark.parametrize("plant", [{"feedback_delay_s": 0.002}])
def test_drop_with_late_feedback_raises_no_false_esc_fault(rig_run, plant):
    rig_run("drop", plant=plant).assert_passed()
