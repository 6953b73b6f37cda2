"""The airborne scenarios (jump, jump-step, drop, fall, estop, pose), run in the rig."""
import math

import numpy as np
import pytest

from wheelleg.hil.run.scenario import RunData
from wheelleg.hil.scenarios import airborne as A
from wheelleg.hil.scenarios.common import level_within, tracks

from sharing import each_run, same_run

PASSING = ("jump", "jump-step", "drop", "fall", "estop", "pose")


@pytest.mark.parametrize("name", each_run(PASSING))
def test_scenario_passes_its_checks(name, rig_run):
    rig_run(name).assert_passed()


@same_run("jump")
def test_jump_reaches_the_issue_aim_and_lands_with_the_wheels_powered_again(rig_run):
    run = rig_run("jump")
    assert A.peak_clearance(run) >= 0.2
    mode = run.heartbeat["Mode"]
    assert mode[-1] == A.BALANCE and A.first_mode(run, A.JUMP) is not None


@same_run("drop")
def test_in_the_air_the_wheels_only_level_the_body(rig_run):
    """Drop, released level: while the heartbeat says AIRBORNE the wheels get only the
    reaction-wheel levelling (under 1 A: the balance law's free-wheeling wheels would ask
    several), and the body stays within 2 deg of level."""
    run = rig_run("drop")
    hb_t, hb_m = run.heartbeat["t"], run.heartbeat["Mode"]
    air = hb_t[hb_m == A.AIRBORNE]
    assert len(air) > 50  # ~0.3 s of free fall at 500 Hz
    for t, amps in run.wheel_current.values():
        # commands of an AIRBORNE tick go out just before its heartbeat, within the tick
        inside = (t > air[0]) & (t < air[-1] - 0.002)
        assert inside.any() and np.all(np.abs(amps[inside]) < 1.0)
    flying = (run.state["t"] > air[0]) & (run.state["t"] < air[-1])
    assert np.degrees(np.abs(run.state["pitch"][flying]).max()) < 2.0


@same_run("fall")
def test_a_fall_is_detected_and_torque_stays_off_until_the_operator_asks(rig_run):
    results = {c.name: c for c in rig_run("fall").checks}
    assert results["heartbeat shows FALLEN"].passed
    assert results["torque off from FALLEN until re-enable"].passed, results
    assert results["heartbeat shows STAND_UP"].passed  # the re-enable is taken


@same_run("fall")
def test_stands_up_after_a_fall_on_operator_command(rig_run):
    """From lying on its nose: the recovery stand (tuck, tilt up) then the stand-up, to BALANCE."""
    run = rig_run("fall")
    results = {c.name: c for c in run.checks}
    assert A.lying(run, 3.0)[0], A.lying(run, 3.0)  # this seed's tumble ends with its wheels down
    assert results["re-enabled: upright over the last 1 s, or off where it cannot stand"].passed, results
    t_up = A.first_mode(run, A.STAND_UP, 3.0)
    assert A.first_mode(run, A.BALANCE, t_up) is not None and A.first_mode(run, A.FALLEN, t_up) is None


def _quat(roll: float, pitch: float) -> tuple:
    """(w, x, y, z) of R = Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp = math.cos(roll / 2), math.sin(roll / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return cp * cr, cp * sr, sp * cr, -sp * sr


@pytest.mark.parametrize("roll, pitch, lying", [
    (2.87, math.radians(89.99), True),  # on its nose, body vertical, turned about the vertical: the plant's ZYX roll
    (0.0, math.radians(50), True),
    (0.0, math.radians(-50), True),  # on its tail
    (math.pi, 0.2, False),  # on its back
    (1.5, 0.3, False),  # on its side
])
def test_the_program_takes_standing_on_its_nose_for_lying_where_it_can_recover(roll, pitch, lying):
    """`fall` on seed 1 (Python program, 2026-12-06) ended with the body vertical on its nose,
    both wheels on the floor; at 90 deg of pitch the ZYX roll is singular and read ~2.9 rad, so
    the program took it for lying on its side and stayed FALLEN. Judged by the tilt from upright
    and the side tilt, it starts the recovery stand (`wheelleg run fall --seed 1` then stood)."""
    from wheelleg.controller.node import Controller
    ctl = Controller()
    ctl.bus.imu.quat = _quat(roll, pitch)
    assert ctl._lying() is lying


@pytest.mark.parametrize("pitch, limit", [(math.radians(50), 1.3), (math.radians(89.99), math.radians(89.99) + 0.1)])
def test_a_recovery_has_fallen_again_past_its_limit_or_a_little_past_its_start(pitch, limit):
    """From a nose-stand the recovery may tilt a little further than it began; from the usual
    ~50 deg it stops at 1.3 rad as every earlier campaign measured it."""
    from wheelleg.controller import params as P
    from wheelleg.controller.node import Controller
    ctl = Controller()
    ctl.bus.imu.quat = _quat(0.0, pitch)
    assert P.RECOVERY_FALL_PITCH == 1.3
    assert ctl._fallen_again_past() == pytest.approx(limit, abs=1e-6)


# -- the checks themselves, on synthetic runs -----------------------------------------
def _run(modes, hip_tau, n_per=10, **state) -> RunData:
    """Heartbeat modes in blocks of ``n_per`` ticks (2 ms), one hip torque per tick."""
    m = np.repeat(np.array(modes), n_per)
    t = np.arange(len(m)) * 0.002
    fields = {k: np.zeros(len(t)) for k in ("pitch", "roll", "x", "z", "left_normal_force", "right_normal_force",
                                            "left_wheel_clearance", "right_wheel_clearance")}
    fields.update({k: np.asarray(v, dtype=float) for k, v in state.items()})
    fields["t"] = t
    return RunData(state=fields, heartbeat={"t": t, "Mode": m}, hip_torque={1: (t, np.asarray(hip_tau, float))},
                   wheel_current={1: (t, np.zeros(len(t)))},
                   events=[{"kind": "operator", "t": 0.07, "Mode": 0}, {"kind": "operator", "t": 0.19, "Mode": 1}])


def test_estop_check_fails_on_torque_after_the_stop_and_on_a_slow_stop():
    modes = [A.BALANCE] * 4 + [A.ESTOP] * 6
    quiet = np.where(np.repeat(np.array(modes), 10) == A.ESTOP, 0.0, 1.0)
    check = A.estops_cut_torque((A.BALANCE,))
    assert check(_run(modes, quiet)).passed
    spiked = quiet.copy()
    spiked[70] = 2.0
    assert not check(_run(modes, spiked)).passed
    slow = [A.BALANCE] * 6 + [A.ESTOP] * 4  # ESTOP 50 ms after the switch
    assert not check(_run(slow, np.where(np.repeat(np.array(slow), 10) == A.ESTOP, 0.0, 1.0))).passed
    assert not A.estops_cut_torque((A.MOVE,))(_run(modes, quiet)).passed  # it was in BALANCE


def _fallen(pitch_deg, roll_deg, wheel_n, modes_after, hip_after) -> RunData:
    """1 s lying as given, re-enabled at 0.5 s; after it ``modes_after`` and ``hip_after`` N m."""
    t = np.arange(500) * 0.002
    after = t >= 0.5
    state = {"t": t, "pitch": np.full(500, np.radians(pitch_deg)), "roll": np.full(500, np.radians(roll_deg)),
             "left_normal_force": np.full(500, wheel_n), "right_normal_force": np.full(500, wheel_n)}
    return RunData(state=state, heartbeat={"t": t, "Mode": np.where(after, modes_after, A.FALLEN)},
                   hip_torque={1: (t, np.where(after, hip_after, 0.0))}, wheel_current={1: (t, np.zeros(500))},
                   events=[{"kind": "operator", "t": 0.5, "Reenable": 1}])


def test_after_a_fall_it_must_stand_where_its_wheels_are_down_and_stay_off_where_not():
    check = A.stands_up_where_it_can(0.2)
    on_back = _fallen(0.0, 180.0, 0.0, A.FALLEN, 0.0)
    assert check(on_back).passed and "on its back" in check(on_back).detail
    assert not check(_fallen(0.0, 180.0, 0.0, A.FALLEN, 0.5)).passed  # torque on its back
    assert not check(_fallen(0.0, 180.0, 0.0, A.STAND_UP, 0.0)).passed  # not FALLEN at the end
    assert not check(_fallen(44.0, 0.0, 10.0, A.FALLEN, 0.0)).passed  # on its nose, wheels down: must stand
    assert "on its side" in check(_fallen(0.0, 100.0, 0.0, A.FALLEN, 0.0)).detail


def test_clearance_and_leave_ground_checks_fail_when_the_wheels_stay_down():
    n = 100
    grounded = _run([A.BALANCE] * 10, np.zeros(n), left_normal_force=np.full(n, 20.0),
                    right_normal_force=np.full(n, 20.0))
    assert not A.leaves_ground()(grounded).passed
    assert not A.clearance_at_least(0.01)(grounded).passed
    lift = np.zeros(n)
    lift[40:80] = 0.25
    flying = _run([A.JUMP] * 10, np.zeros(n), left_wheel_clearance=lift, right_wheel_clearance=lift,
                  left_normal_force=np.where(lift > 0, 0.0, 20.0), right_normal_force=np.where(lift > 0, 0.0, 20.0))
    assert A.leaves_ground()(flying).passed and A.clearance_at_least(0.2)(flying).passed
    assert not A.clearance_at_least(0.3)(flying).passed


def test_factories_size_their_scenarios_and_refuse_nonsense():
    assert A.drop_scenario(0.8).start is not None and "80 cm" in A.drop_scenario(0.8).summary
    assert A.jump_step_scenario(0.2).terrain[0].height_m == 0.2
    for make in (lambda: A.drop_scenario(0.0), lambda: A.jump_scenario(-0.1),
                 lambda: A.jump_step_scenario(float("nan")), lambda: A.jump_step_scenario(0.1, approach_m=0.0)):
        with pytest.raises(ValueError):
            make()


@same_run("jump")
def test_sim_state_schema_gives_the_airborne_fields_their_units(rig_run):
    from wheelleg.hil.record import schemas
    run = rig_run("jump")
    extra = [k for k in run.state if k not in schemas.SIM_STATE_FIELDS]
    assert {"left_wheel_clearance", "right_wheel_clearance", "body_on_ground"} <= set(extra)
    props = schemas.sim_state_schema(extra)["properties"]
    assert props["left_wheel_clearance"]["description"].startswith("[m]")
    assert "left_wheel_clearance" not in schemas.sim_state_schema()["required"]


def test_pose_is_judged_from_the_level_stance_and_the_stance_within_the_mount_tilt():
    """A body whose IMU sits 1.4 deg off holds every pose 1.4 deg off: the change from its level
    stance is the program's (within 1 deg), the stance within the mount's 1.5 deg plus 1."""
    t = np.arange(0, 2.0, 0.002)
    asked = np.where(t < 1.0, 0.1, 0.0)  # 0.1 rad over 0-1 s, level after

    def run(offset_rad, error_rad=0.0):
        return RunData(state={"t": t, "pitch": asked + offset_rad + np.where(t < 1.0, error_rad, 0.0)},
                       heartbeat={}, hip_torque={}, wheel_current={})

    holds = tracks("pitch", 0.1, 0.5, 1.0, A.POSE_HOLD_RAD, level=(1.5, 2.0))
    level = level_within("pitch", 1.5, 2.0, A.IMU_MOUNT_TILT_RAD + A.POSE_HOLD_RAD)
    tilted = run(np.radians(1.4))
    assert holds(tilted).passed and level(tilted).passed
    assert not tracks("pitch", 0.1, 0.5, 1.0, A.POSE_HOLD_RAD)(tilted).passed  # judged absolutely: the tilt
    assert not holds(run(0.0, np.radians(1.2))).passed  # the pose itself 1.2 deg short
    assert not level(run(np.radians(2.7))).passed  # a stance past any mount's tilt
