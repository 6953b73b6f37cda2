"""The quadruped's MuJoCo model (emulators/quadruped/) against its description and the controller's belief.

- the compiled model holds the description's numbers (masses, ranges, hips, links, motors);
- every scene steps without MuJoCo warnings (standing held, pushed, by a step, lying, on its side);
- at the nominal values the plant's feet are where the controller's kinematics put them, and
  the finite-difference Jacobian of MuJoCo's foot is the controller's analytic one;
- joint torque signs: for a known ground reaction on each foot, the motor torques MuJoCo needs to hold
  it are tau = -J^T R (the controller's ``torques_for_reaction``, the seed's sign trap), and those
  torques, commanded, leave no generalised force on the leg's joints.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import kinematics as K
from wheelleg.emulators.quadruped import description as D
from wheelleg.emulators.quadruped.physics import JOINT_NAMES, QuadrupedPhysics, stance_angles
from wheelleg.emulators.terrain import TerrainFeature

LEG_INDEX = {leg: i for i, leg in enumerate(D.LEGS)}


@pytest.fixture(scope="module")
def phys() -> QuadrupedPhysics:
    return QuadrupedPhysics()


# --- the model holds the description ------------------------------------------------------------------
def test_masses_and_the_motors_are_the_descriptions(phys):
    m = phys.model
    assert float(np.sum(m.body_mass)) == pytest.approx(D.total_mass_kg(), abs=1e-9)
    assert 10.0 <= D.total_mass_kg() <= 15.0
    assert m.body("body").mass[0] == pytest.approx(D.MASS_BODY_KG + D.MASS_PAYLOAD_KG)
    np.testing.assert_allclose(m.body("body").inertia, D.body_inertia_kg_m2(), rtol=1e-9)
    assert [m.actuator(i).name for i in range(m.nu)] == list(JOINT_NAMES)
    for motor in D.JOINT_MOTORS:
        j = m.joint(motor.name)
        np.testing.assert_allclose(j.range, motor.range_rad, atol=1e-6)
        assert j.armature[0] == pytest.approx(D.JOINT_ARMATURE_KG_M2, rel=1e-4)
        np.testing.assert_allclose(m.actuator(motor.name).ctrlrange, [-D.CG_TORQUE_LIMIT_NM, D.CG_TORQUE_LIMIT_NM])
        axis = [1, 0, 0] if motor.joint == "abduction" else [0, 1, 0]
        np.testing.assert_array_equal(j.axis, axis)


def test_wiring_is_the_contracts_ids_and_buses():
    ids = {m.name: m.motor_id for m in D.JOINT_MOTORS}
    assert ids["FR_abduction"] == 1 and ids["FL_calf"] == 6 and ids["RR_abduction"] == 7 and ids["RL_calf"] == 12
    assert all(m.motor_id == 1 + 3 * D.LEGS.index(m.leg) + D.JOINTS.index(m.joint) for m in D.JOINT_MOTORS)
    assert {m.bus for m in D.JOINT_MOTORS if m.leg in ("FR", "FL")} == {0}
    assert {m.bus for m in D.JOINT_MOTORS if m.leg in ("RR", "RL")} == {1}
    assert [m.motor_id for m in D.JOINT_MOTORS] == list(C.MOTOR_IDS)  # the controller's belief agrees


def test_hips_and_links_are_where_the_description_puts_them(phys):
    m = phys.model
    for leg in D.LEGS:
        np.testing.assert_allclose(m.body(f"{leg}_abduction").pos, D.hip_position_m(leg), atol=1e-9)
        np.testing.assert_allclose(m.body(f"{leg}_thigh").pos, [0, D.side_sign(leg) * D.ABDUCTION_LINK_M, 0])
        np.testing.assert_allclose(m.body(f"{leg}_calf").pos, [0, 0, -D.THIGH_M])
        np.testing.assert_allclose(m.site(f"{leg}_foot").pos, [0, 0, -D.CALF_M])
        assert m.geom(f"{leg}_foot").size[0] == pytest.approx(D.FOOT_RADIUS_M)


# --- every scene steps cleanly -----------------------------------------------------------------------
def _hold(phys: QuadrupedPhysics, goal: dict, seconds: float, kp: float = 40.0, kd: float = 0.8) -> None:
    for _ in range(round(seconds / phys.model.opt.timestep)):
        torques = {}
        for name in JOINT_NAMES:
            q, w = phys.shaft_state(name)
            torques[name] = kp * (goal[name] - q) - kd * w
        phys.set_torques(torques)
        phys.step()


SCENES = {
    "flat": (),
    "step_up": (TerrainFeature.step(x_m=0.3, height_m=0.04),),
    "bump": (TerrainFeature.bump(x_m=0.16, y_m=-0.14, height_m=0.03),),
    "wall": (TerrainFeature.wall(x_m=0.3, height_m=0.1),),
}


@pytest.mark.parametrize("name", SCENES)
def test_scene_steps_standing_and_pushed_without_warnings(name):
    """Standing, joints held by a PD, pushed forward at 40 N for 0.5 s: MuJoCo never warns, it stays up."""
    phys = QuadrupedPhysics(terrain=SCENES[name])
    phys.reset_standing(0.25)
    goal = {n: phys.shaft_state(n)[0] for n in JOINT_NAMES}
    phys.apply_body_force([40.0, 0.0, 0.0])
    _hold(phys, goal, 0.5)
    pushed_x = phys.ground_truth()["x"]
    phys.apply_body_force([0.0, 0.0, 0.0])
    _hold(phys, goal, 1.0)
    assert phys.warnings() == {}
    truth = phys.ground_truth()
    assert all(math.isfinite(v) for v in truth.values())
    assert pushed_x > 0.002  # the push leaned it forward on its legs
    assert truth["z"] > 0.15 and truth["body_on_ground"] == 0.0
    assert sum(truth[f"{leg}_foot_force"] for leg in D.LEGS) == pytest.approx(D.total_mass_kg() * 9.81, rel=0.15)


@pytest.mark.parametrize("on_side", [False, True])
def test_lying_poses_settle_without_warnings(on_side):
    phys = QuadrupedPhysics()
    phys.reset_lying(on_side=on_side)
    truth = phys.ground_truth()
    assert phys.warnings() == {}
    assert truth["t"] == 0.0 and truth["body_on_ground"] == 1.0
    assert abs(truth["vx"]) + abs(truth["vz"]) + abs(truth["wx"]) < 0.01  # at rest
    if on_side:
        assert math.degrees(truth["roll"]) < -40.0  # leaning on its left side
    else:
        assert abs(math.degrees(truth["roll"])) < 2.0 and truth["z"] < 0.08


def test_standing_height_is_the_hip_plane_above_the_feet(phys):
    for height in (0.18, 0.25, 0.28):
        phys.reset_standing(height)
        assert phys.ground_truth()["height"] == pytest.approx(height, abs=1e-9)
        assert phys.ground_truth()["z"] == pytest.approx(height + D.FOOT_RADIUS_M, abs=1e-9)
    with pytest.raises(ValueError, match="a leg reaches"):
        stance_angles(0.5)


# --- the plant's legs against the controller's kinematics ------------------------------------------
def _poses(leg: str, n: int = 12) -> list[np.ndarray]:
    """Joint angles (3,) spread over the leg's ranges (a fixed draw)."""
    rng = np.random.default_rng(LEG_INDEX[leg])
    motors = [m for m in D.JOINT_MOTORS if m.leg == leg]
    return [np.array([rng.uniform(*m.range_rad) for m in motors]) for _ in range(n)]


def _foot_in_leg_frame(phys: QuadrupedPhysics, leg: str, q: np.ndarray) -> np.ndarray:
    """MuJoCo's foot centre (m, (3,)) relative to the abduction joint, body level at the origin."""
    d = phys.data
    mujoco.mj_resetData(phys.model, d)
    for motor, angle in zip([m for m in D.JOINT_MOTORS if m.leg == leg], q):
        d.qpos[phys.model.joint(motor.name).qposadr[0]] = angle
    mujoco.mj_kinematics(phys.model, d)
    return d.site(f"{leg}_foot").xpos - d.qpos[:3] - np.array(D.hip_position_m(leg))


@pytest.mark.parametrize("leg", D.LEGS)
def test_feet_are_where_the_controllers_forward_kinematics_puts_them(leg):
    phys = QuadrupedPhysics()
    for q in _poses(leg):
        np.testing.assert_allclose(_foot_in_leg_frame(phys, leg, q), K.forward(q, D.side_sign(leg), C.GEOMETRY),
                                   atol=1e-12)


@pytest.mark.parametrize("leg", D.LEGS)
def test_mujocos_finite_difference_jacobian_is_the_controllers(leg):
    phys, h = QuadrupedPhysics(), 1e-6
    for q in _poses(leg, 6):
        fd = np.column_stack([(_foot_in_leg_frame(phys, leg, q + h * e) - _foot_in_leg_frame(phys, leg, q - h * e))
                              / (2 * h) for e in np.eye(3)])
        np.testing.assert_allclose(fd, K.jacobian(q, D.side_sign(leg), C.GEOMETRY), atol=1e-7)


REACTIONS = [np.array(r) for r in ((0.0, 0.0, 30.0), (8.0, -5.0, 25.0), (-6.0, 4.0, 0.0))]  # N, ground on foot


@pytest.mark.parametrize("leg", D.LEGS)
def test_joint_torque_signs_for_a_known_foot_force(leg):
    """No gravity, at rest, in the air: a ground reaction R on the foot needs motor torques that cancel its
    generalised force on the leg's joints. MuJoCo's (from its own tree, mj_applyFT) are the controller's
    -J^T R, and commanding those leaves the joints balanced (actuator gear and axis signs)."""
    phys = QuadrupedPhysics()
    m, d = phys.model, phys.data
    m.opt.gravity[:] = 0.0
    dofs = [m.joint(f"{leg}_{j}").dofadr[0] for j in D.JOINTS]
    calf = m.body(f"{leg}_calf").id
    for q in (np.array([a["abduction"], a["thigh"], a["calf"]]) for a in (stance_angles(0.22), stance_angles(0.27))):
        for q_try in (q, q + np.array([0.2, -0.3, 0.25])):
            for reaction in REACTIONS:
                mujoco.mj_resetData(m, d)
                d.qpos[2] = 1.0
                d.qpos[[m.joint(f"{leg}_{j}").qposadr[0] for j in D.JOINTS]] = q_try
                mujoco.mj_forward(m, d)
                qfrc = np.zeros(m.nv)
                mujoco.mj_applyFT(m, d, reaction, np.zeros(3), d.site(f"{leg}_foot").xpos.copy(), calf, qfrc)
                needed = -qfrc[dofs]
                ours = K.torques_for_reaction(q_try, D.side_sign(leg), C.GEOMETRY, reaction)
                np.testing.assert_allclose(needed, ours, atol=1e-9)
                d.ctrl[:] = 0.0
                d.ctrl[[m.actuator(f"{leg}_{j}").id for j in D.JOINTS]] = ours
                mujoco.mj_forward(m, d)
                np.testing.assert_allclose(d.qfrc_actuator[dofs] + qfrc[dofs], 0.0, atol=1e-9)
                if q_try is q and not reaction[:2].any():  # foot under the thigh axis, pushed up:
                    # the knee extends, the thigh has no arm, the abduction holds the foot's offset l1
                    assert ours[2] > 0.0 and ours[1] == pytest.approx(0.0, abs=1e-9), (leg, ours)
                    assert ours[0] == pytest.approx(-D.side_sign(leg) * D.ABDUCTION_LINK_M * reaction[2])


def test_the_body_overrides_reach_the_quadrupeds_model():
    nominal = QuadrupedPhysics().model
    changed = QuadrupedPhysics(overrides={"body_mass_scale": 1.2, "com_x_m": 0.02}).model
    assert changed.body("body").mass[0] == pytest.approx(1.2 * nominal.body("body").mass[0])
    np.testing.assert_allclose(changed.body("body").ipos, [0.02, 0.0, 0.0])
