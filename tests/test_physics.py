"""emulators/physics.py: resets, torques, readings, ground truth, determinism."""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.emulators.physics import HIP_NAMES, Physics, TerrainFeature, euler_zyx, leg_joint_angles

WEIGHT_PER_WHEEL_N = C.MASS_TOTAL * C.GRAVITY / 2
TRUTH_KEYS = {"t", "x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz", "wx", "wy", "wz",
              "left_leg_length", "right_leg_length", "left_leg_angle", "right_leg_angle",
              "left_normal_force", "right_normal_force", "body_on_ground",
              "left_wheel_clearance", "right_wheel_clearance"}


def hold_legs(phys: Physics, leg_length_m: float, seconds: float, wheels_nm=None, every_step=None) -> None:
    """Hips held at ``leg_length_m`` (legs vertical in the body) by a PD plus the
    gravity feed-forward of the design document's VMC (T = J^T F); wheels get ``wheels_nm``."""
    phi1, phi4 = fivebar.inverse_kinematics(leg_length_m, math.pi / 2)
    k = fivebar.forward_kinematics(phi1, phi4)
    push_n = (C.MASS_BODY / 2 + 2 * C.MASS_LINK_THIGH + 2 * C.MASS_LINK_SHIN) * C.GRAVITY
    t1, t4 = fivebar.joint_torques(k, push_n, 0.0)
    goal, feed = {}, {}
    for j in C.JOINTS:
        phi, torque = (phi1, t1) if j.hip == "A" else (phi4, t4)
        goal[j.name], feed[j.name] = fivebar.shaft_from_phi(j, phi), fivebar.shaft_torque(j, torque)
    for _ in range(round(seconds / phys.model.opt.timestep)):
        torques = {}
        for n in HIP_NAMES:
            q, w = phys.shaft_state(n)
            torques[n] = feed[n] + 40.0 * (goal[n] - q) - 0.5 * w
        phys.set_torques(torques, wheels_nm or {})
        phys.step()
        if every_step:
            every_step(phys)


def wheel_x(phys: Physics, name: str) -> float:
    """World x (m) of a wheel's centre at the current state."""
    mujoco.mj_kinematics(phys.model, phys.data)
    return float(phys.data.xpos[mujoco.mj_name2id(phys.model, mujoco.mjtObj.mjOBJ_BODY, name)][0])


# --- reset_standing --------------------------------------------------------------------
@pytest.mark.parametrize("leg_length", [0.12, 0.17, 0.25])
def test_reset_standing_leg_length_and_wheels_on_ground(leg_length):
    phys = Physics()
    phys.reset_standing(leg_length, x_m=0.3, y_m=-0.2, yaw_rad=0.7)
    truth = phys.ground_truth()
    assert set(truth) == TRUTH_KEYS
    for leg in ("left", "right"):
        assert truth[f"{leg}_leg_length"] == pytest.approx(leg_length, abs=1e-3)
        assert truth[f"{leg}_leg_angle"] == pytest.approx(0.0, abs=1e-9)
        assert truth[f"{leg}_wheel_clearance"] == pytest.approx(0.0, abs=1e-6)
    assert (truth["x"], truth["y"], truth["yaw"]) == pytest.approx((0.3, -0.2, 0.7), abs=1e-12)
    assert truth["t"] == 0.0 and truth["vx"] == 0.0 and truth["wy"] == 0.0
    # closed loops: the equality constraints are satisfied
    d = phys.data
    eq = d.efc_type[:d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
    np.testing.assert_allclose(d.efc_pos[:d.nefc][eq], 0.0, atol=1e-9)
    hold_legs(phys, leg_length, 0.4)
    truth = phys.ground_truth()
    for leg in ("left", "right"):
        assert truth[f"{leg}_leg_length"] == pytest.approx(leg_length, abs=1e-3)
        assert truth[f"{leg}_normal_force"] == pytest.approx(WEIGHT_PER_WHEEL_N, rel=0.03)
    assert truth["body_on_ground"] == 0.0
    assert phys.warnings() == {}


def test_reset_standing_drop_height_and_platform():
    phys = Physics(terrain=[TerrainFeature.step(x_m=0.5, height_m=-0.1)])  # on a 10 cm platform
    phys.reset_standing(0.17, drop_height_m=0.08)
    truth = phys.ground_truth()
    assert truth["left_wheel_clearance"] == pytest.approx(0.08, abs=1e-6)
    assert truth["right_wheel_clearance"] == pytest.approx(0.08, abs=1e-6)
    # CoM above the wheel axle: leg + hip offset; axle one radius above the 0.1 m platform
    assert truth["z"] == pytest.approx(0.1 + 0.08 + C.WHEEL_RADIUS + 0.17 + C.BODY_COM_ABOVE_HIP, abs=1e-6)


def test_reset_standing_fits_legs_to_a_bump():
    bump = TerrainFeature.bump(x_m=0.0, y_m=C.HALF_TRACK, height_m=0.03)
    phys = Physics(terrain=[bump])
    phys.reset_standing(0.17, fit_legs_to_ground=True)
    truth = phys.ground_truth()
    assert truth["left_leg_length"] == pytest.approx(0.17, abs=1e-6)  # on the bump
    assert truth["right_leg_length"] == pytest.approx(0.20, abs=1e-4)
    assert truth["left_wheel_clearance"] == pytest.approx(0.0, abs=1e-6)
    assert truth["right_wheel_clearance"] == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("bad", [dict(leg_length_m=0.05), dict(leg_length_m=0.3), dict(x_m=math.nan),
                                 dict(drop_height_m=-0.1)])
def test_reset_standing_rejects_bad_input(bad):
    with pytest.raises(ValueError):
        Physics().reset_standing(**{"leg_length_m": 0.17, **bad})


# --- reset_resting -------------------------------------------------------------------
def test_reset_resting_lies_on_the_stops_and_stays():
    phys = Physics()
    phys.reset_resting()
    assert phys.time_s == 0.0
    for n in HIP_NAMES:
        q, w = phys.shaft_state(n)
        assert abs(q) < 2e-3 and abs(w) < 1e-4, n
    truth = phys.ground_truth()
    assert truth["body_on_ground"] == 1.0
    assert truth["pitch"] > 0.5  # toppled forward, nose down
    assert max(abs(truth[k]) for k in ("vx", "vy", "vz", "wx", "wy", "wz")) < 1e-3
    # with no torque it stays there, thighs on their stops
    phys.step(500)
    for n in HIP_NAMES:
        assert abs(phys.shaft_state(n)[0]) < 2e-3, n
    assert phys.ground_truth()["pitch"] == pytest.approx(truth["pitch"], abs=1e-3)
    assert phys.warnings() == {}


# --- torques and signs ----------------------------------------------------------------
@pytest.mark.parametrize("wheel", C.WHEELS, ids=lambda w: w.name)
def test_positive_wheel_torque_rolls_as_constants_say(wheel):
    """Legs held, +0.5 N m on one wheel for 0.1 s: the left wheel rolls forward,
    the right one backward (constants.WHEELS forward_sign); either way the
    robot turns clockwise seen from above."""
    phys = Physics()
    phys.reset_standing(0.17)
    before = wheel_x(phys, wheel.name)
    hold_legs(phys, 0.17, 0.1, wheels_nm={wheel.name: 0.5})
    moved = wheel_x(phys, wheel.name) - before
    assert moved * wheel.forward_sign > 0.01
    assert phys.shaft_state(wheel.name)[1] > 0  # the shaft turns the way it is pushed
    truth = phys.ground_truth()
    assert truth["yaw"] < -0.01
    assert abs(truth["pitch"]) < 0.1  # still standing: it rolled, it did not fall


def test_leg_angle_sign_wheel_behind_hips_is_positive():
    phys = Physics()
    # a level body with both legs swung back by 0.3 rad (phi0 = pi/2 - 0.3)
    phys.reset_standing(0.17)
    phi1, phi4 = fivebar.inverse_kinematics(0.17, math.pi / 2 - 0.3)
    for leg in ("left", "right"):
        for joint, angle in leg_joint_angles(leg, phi1, phi4).items():
            phys.data.qpos[phys.model.jnt_qposadr[phys.model.joint(joint).id]] = angle
    mujoco.mj_forward(phys.model, phys.data)
    truth = phys.ground_truth()
    assert wheel_x(phys, "left_wheel") < truth["x"]  # the wheel is behind the hips
    assert truth["left_leg_angle"] == pytest.approx(0.3, abs=1e-9)
    assert truth["right_leg_angle"] == pytest.approx(0.3, abs=1e-9)
    assert truth["left_leg_length"] == pytest.approx(0.17, abs=1e-9)


def test_pitch_nose_down_swings_the_wheels_back():
    """theta = pi/2 - phi0 - phi with phi = -pitch: legs straight in the body,
    a nose-down pitch p puts the wheels behind the hips at theta = p."""
    phys = Physics()
    phys.reset_standing(0.17, pitch_rad=0.2)
    truth = phys.ground_truth()
    assert truth["pitch"] == pytest.approx(0.2, abs=1e-12)
    assert truth["left_leg_angle"] == pytest.approx(0.2, abs=1e-9)
    assert wheel_x(phys, "left_wheel") < truth["x"]


def test_torques_are_validated_and_clipped():
    phys = Physics()
    with pytest.raises(KeyError):
        phys.set_torques({"left_knee": 1.0}, {})
    with pytest.raises(KeyError):
        phys.set_torques({}, {"left_front_hip": 1.0})  # a hip in the wheels' dict
    with pytest.raises(ValueError):
        phys.set_torques({"left_front_hip": math.nan}, {})
    with pytest.raises(KeyError):
        phys.shaft_state("nope")
    phys.reset_standing(0.17)
    phys.set_torques({"left_front_hip": 100.0}, {"left_wheel": -100.0})
    phys.step()
    assert phys.data.actuator_force[phys.model.actuator("left_front_hip").id] == C.CG_TORQUE_LIMIT
    assert phys.data.actuator_force[phys.model.actuator("left_wheel").id] == -C.WHEEL_TORQUE_LIMIT


def test_motor_torques_in_order_are_the_torques_by_name():
    """The plant's per-step path (``set_motor_torques``, ``motor_states``) is ``set_torques`` and
    ``shaft_state`` by position: the same ctrl, the same readings; bad input refused by name."""
    torques = [0.5, -1.25, 2.0, -0.75, 0.3, -0.6]  # Physics.MOTORS order: hips, then wheels
    by_name, in_order = Physics(), Physics()
    for phys in (by_name, in_order):
        phys.reset_standing(0.17)
    by_name.set_torques(dict(zip(HIP_NAMES, torques[:4])), dict(zip(Physics.MOTORS[4:], torques[4:])))
    in_order.set_motor_torques(torques)
    assert in_order.data.ctrl.tolist() == by_name.data.ctrl.tolist()
    for phys in (by_name, in_order):
        phys.step(5)
    assert in_order.motor_states() == [by_name.shaft_state(name) for name in Physics.MOTORS]
    with pytest.raises(ValueError, match="need 6 torques"):
        in_order.set_motor_torques(torques[:5])
    with pytest.raises(ValueError, match="right_front_hip must be finite"):
        in_order.set_motor_torques([0.0, 0.0, math.inf, 0.0, 0.0, 0.0])
    assert in_order.data.ctrl.tolist() == by_name.data.ctrl.tolist()  # a refused call writes nothing


# --- IMU -----------------------------------------------------------------------------------
def test_imu_at_rest_standing():
    phys = Physics()
    phys.reset_standing(0.17)
    hold_legs(phys, 0.17, 0.3)
    quat, gyro, accel = phys.imu()
    assert quat.shape == (4,) and gyro.shape == (3,) and accel.shape == (3,)
    np.testing.assert_allclose(quat, [1, 0, 0, 0], atol=5e-3)
    np.testing.assert_allclose(gyro, 0.0, atol=0.05)
    assert accel[2] == pytest.approx(C.GRAVITY, abs=0.05)
    np.testing.assert_allclose(accel[:2], 0.0, atol=0.05)


def test_imu_frame_when_lying_nose_down():
    """Specific force in the body frame of a nose-down (pitch p) body: g (-sin p, 0, cos p)."""
    phys = Physics()
    phys.reset_resting()
    phys.step(10)
    quat, gyro, accel = phys.imu()
    pitch = phys.ground_truth()["pitch"]
    assert euler_zyx(quat)[1] == pytest.approx(pitch, abs=1e-6)
    np.testing.assert_allclose(accel, C.GRAVITY * np.array([-math.sin(pitch), 0.0, math.cos(pitch)]), atol=0.02)
    np.testing.assert_allclose(gyro, 0.0, atol=1e-3)


# --- body force -------------------------------------------------------------------------------
def robot_momentum_x(phys: Physics) -> float:
    """x momentum (kg m/s) of the whole robot at the current state."""
    mujoco.mj_forward(phys.model, phys.data)
    total, vel = 0.0, np.zeros(6)
    for b in range(1, phys.model.nbody):
        mujoco.mj_objectVelocity(phys.model, phys.data, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)
        total += phys.model.body_mass[b] * vel[3]  # linear velocity of the body's CoM, world
    return total


def test_body_force_pushes_and_releases():
    phys = Physics()
    phys.model.opt.gravity[:] = 0.0
    phys.reset_standing(0.17, drop_height_m=0.5)
    phys.apply_body_force(np.array([10.0, 0.0, 0.0]), point_body_m=(0.0, 0.0, 0.1))
    phys.step(100)
    assert robot_momentum_x(phys) == pytest.approx(1.0, rel=0.01)  # 10 N for 0.1 s
    assert phys.ground_truth()["wy"] > 0.1  # pushed above the CoM: nose down
    phys.apply_body_force(np.zeros(3))
    phys.step(100)
    assert not phys.data.xfrc_applied.any()
    assert robot_momentum_x(phys) == pytest.approx(1.0, rel=0.01)  # released: nothing more
    with pytest.raises(ValueError):
        phys.apply_body_force([1.0, 2.0])


# --- determinism -------------------------------------------------------------------------------
def _run(read_every_step: bool) -> bytes:
    ball = TerrainFeature.projectile(0.3, 0.04, (-0.6, 0.0, 0.3), (4.0, 0.0, 0.8))
    phys = Physics(terrain=[ball, TerrainFeature.bump(0.2, C.HALF_TRACK, 0.02)])
    phys.reset_resting()
    phys.reset_standing(0.17)
    reader = (lambda p: (p.ground_truth(), p.imu())) if read_every_step else None
    phys.apply_body_force([3.0, 1.0, 0.0], (0.05, 0.0, 0.02))
    hold_legs(phys, 0.17, 0.4, wheels_nm={"left_wheel": 0.3, "right_wheel": -0.2}, every_step=reader)
    d = phys.data
    return b"".join(np.ascontiguousarray(a).tobytes() for a in (d.qpos, d.qvel, d.qacc_warmstart, d.sensordata))


def test_same_calls_give_bit_identical_states():
    first = _run(read_every_step=False)
    assert _run(read_every_step=False) == first
    # reading the truth and the IMU never changes the simulation
    assert _run(read_every_step=True) == first


# --- terrain ------------------------------------------------------------------------------------
def test_projectile_starts_where_asked_and_can_be_relaunched():
    ball = TerrainFeature.projectile(0.5, 0.05, (-1.0, 0.5, 0.3), (2.0, 0.0, 0.0))
    phys = Physics(terrain=[ball])
    phys.reset_standing(0.17)
    body = phys.model.body(phys.terrain_names[0]).id
    mujoco.mj_kinematics(phys.model, phys.data)
    np.testing.assert_allclose(phys.data.xpos[body], (-1.0, 0.5, 0.3))
    phys.launch_projectile(0, (0.0, 1.0, 0.5), (0.0, 0.0, 0.0))
    phys.step(100)  # falls freely for 0.1 s
    assert phys.data.xpos[body][2] == pytest.approx(0.5 - 0.5 * 9.81 * 0.1**2, abs=2e-3)
    with pytest.raises(IndexError):
        phys.launch_projectile(1, (0, 0, 0), (0, 0, 0))


@pytest.mark.parametrize("bad", [dict(kind="hole"), dict(kind="step", height_m=0.0),
                                 dict(kind="slope", angle_rad=0.0), dict(kind="bump", height_m=-0.01),
                                 dict(kind="bump", height_m=0.02, shape="cone"),
                                 dict(kind="wall", height_m=0.1, width_m=-1.0),
                                 dict(kind="projectile", mass_kg=0.0, radius_m=0.05)])
def test_terrain_rejects_bad_features(bad):
    with pytest.raises(ValueError):
        TerrainFeature(**bad)


def test_side_slope_tilts_the_ground_the_asked_way():
    """angle > 0 raises the left side: the right leg must be the longer one."""
    phys = Physics(terrain=[TerrainFeature.slope(angle_rad=math.radians(10))])
    phys.reset_standing(0.17, fit_legs_to_ground=True)
    truth = phys.ground_truth()
    expected = 2 * C.HALF_TRACK * math.tan(math.radians(10))
    assert truth["right_leg_length"] - truth["left_leg_length"] == pytest.approx(expected, abs=3e-3)
