"""The MJCF robot agrees with its description (emulators/robot/description.py), and at
the nominal values with what the controller believes (controller/constants.py and its
five-bar kinematics): a plant override may move the truth, the nominal robot is the
one the controller was designed for.

Everything is read from the compiled model (MjModel) or measured in
simulation, never parsed from the XML text.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.emulators.physics import HIP_NAMES, SCENE_PATH, Physics, TerrainFeature
from wheelleg.emulators.robot import description as D

LEGS = ("left", "right")
SIDE = {"left": +1.0, "right": -1.0}
WHEEL_NAMES = tuple(w.name for w in D.WHEEL_DRIVES)
# what the description's numbers imply (kg, kg m^2, N m)
MASS_LEG = 2 * D.MASS_LINK_THIGH_KG + 2 * D.MASS_LINK_SHIN_KG + D.MASS_WHEEL_MOTOR_KG
MASS_TOTAL = D.MASS_BODY_KG + 2 * MASS_LEG + 2 * D.MASS_WHEEL_KG
_X, _Y, _Z = D.BODY_SIZE_M
BODY_INERTIA = tuple(D.MASS_BODY_KG * (a * a + b * b) / 12 for a, b in ((_Y, _Z), (_X, _Z), (_X, _Y)))  # solid box
WHEEL_INERTIA = 0.5 * D.MASS_WHEEL_KG * D.WHEEL_RADIUS_M ** 2  # solid disc about its axle
WHEEL_TORQUE_LIMIT = D.C620_CURRENT_LIMIT_A * D.M3508_TORQUE_CONSTANT_NM_PER_A
HIP_ARMATURE = D.CG_ROTOR_INERTIA_KG_M2 * D.CG_GEAR ** 2  # rotor reflected through the gear
WHEEL_ARMATURE = D.M3508_ROTOR_INERTIA_KG_M2 * D.M3508_GEAR ** 2


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(SCENE_PATH))


def _id(m, kind, name):
    i = mujoco.mj_name2id(m, kind, name)
    assert i >= 0, f"no {kind.name} named {name}"
    return i


def _body(m, name):
    return _id(m, mujoco.mjtObj.mjOBJ_BODY, name)


# --- masses, sizes, limits ----------------------------------------------------------
def test_masses_match_description(model):
    m = model
    assert m.body_mass[_body(m, "body")] == pytest.approx(D.MASS_BODY_KG, abs=1e-9)
    assert m.body_subtreemass[_body(m, "body")] == pytest.approx(MASS_TOTAL, abs=1e-9)
    for leg in LEGS:
        leg_bodies = [f"{leg}_front_thigh", f"{leg}_rear_thigh", f"{leg}_front_shin", f"{leg}_rear_shin"]
        assert sum(m.body_mass[_body(m, b)] for b in leg_bodies) == pytest.approx(MASS_LEG, abs=1e-9)
        for hip in ("front", "rear"):
            assert m.body_mass[_body(m, f"{leg}_{hip}_thigh")] == pytest.approx(D.MASS_LINK_THIGH_KG, abs=1e-9)
        # the M3508 at C rides on link BC (the front shin)
        assert m.body_mass[_body(m, f"{leg}_front_shin")] == pytest.approx(
            D.MASS_LINK_SHIN_KG + D.MASS_WHEEL_MOTOR_KG, abs=1e-9)
        assert m.body_mass[_body(m, f"{leg}_rear_shin")] == pytest.approx(D.MASS_LINK_SHIN_KG, abs=1e-9)
        assert m.body_mass[_body(m, f"{leg}_wheel")] == pytest.approx(D.MASS_WHEEL_KG, abs=1e-9)


def test_body_inertia_size_and_com(model):
    m = model
    b = _body(m, "body")
    np.testing.assert_allclose(m.body_inertia[b], BODY_INERTIA, rtol=1e-9)
    np.testing.assert_allclose(m.body_ipos[b], 0.0, atol=1e-12)  # the body frame is at its CoM
    box = _id(m, mujoco.mjtObj.mjOBJ_GEOM, "body_box")
    np.testing.assert_allclose(2 * m.geom_size[box], D.BODY_SIZE_M, rtol=1e-12)
    for leg in LEGS:
        for hip, x in (("front", D.L5_M / 2), ("rear", -D.L5_M / 2)):
            np.testing.assert_allclose(m.body_pos[_body(m, f"{leg}_{hip}_thigh")],
                                       [x, SIDE[leg] * D.LEG_PLANE_Y_M, -D.BODY_COM_ABOVE_HIP_M], atol=1e-12)


def test_link_lengths_match_description(model):
    m = model
    site = lambda name: m.site_pos[_id(m, mujoco.mjtObj.mjOBJ_SITE, name)]  # noqa: E731
    for leg in LEGS:
        a, e = m.body_pos[_body(m, f"{leg}_front_thigh")], m.body_pos[_body(m, f"{leg}_rear_thigh")]
        assert np.linalg.norm(a - e) == pytest.approx(D.L5_M, abs=1e-9)
        assert np.linalg.norm(m.body_pos[_body(m, f"{leg}_front_shin")]) == pytest.approx(D.L1_M, abs=1e-9)
        assert np.linalg.norm(m.body_pos[_body(m, f"{leg}_rear_shin")]) == pytest.approx(D.L4_M, abs=1e-9)
        assert np.linalg.norm(site(f"{leg}_front_c")) == pytest.approx(D.L2_M, abs=1e-9)
        assert np.linalg.norm(site(f"{leg}_rear_c")) == pytest.approx(D.L3_M, abs=1e-9)


def test_wheels_radius_width_inertia_and_track(model):
    m = model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    body = _body(m, "body")
    for leg in LEGS:
        g = _id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{leg}_wheel")
        assert m.geom_type[g] == mujoco.mjtGeom.mjGEOM_CYLINDER
        assert m.geom_size[g][0] == pytest.approx(D.WHEEL_RADIUS_M, abs=1e-12)
        assert 2 * m.geom_size[g][1] == pytest.approx(D.WHEEL_WIDTH_M, abs=1e-12)
        # wheel centre in the body frame, on the axle line at y = +-HALF_TRACK
        rel = d.xmat[body].reshape(3, 3).T @ (d.geom_xpos[g] - d.xpos[body])
        assert rel[1] == pytest.approx(SIDE[leg] * D.HALF_TRACK_M, abs=1e-9)
        # its axle along y, and its inertia about the axle that of a solid disc
        wheel = _body(m, f"{leg}_wheel")
        principal = d.ximat[wheel].reshape(3, 3)  # the wheel's inertia frame in the world
        axle = principal @ np.diag(m.body_inertia[wheel]) @ principal.T
        assert axle[1, 1] == pytest.approx(WHEEL_INERTIA, rel=1e-9)


def test_actuators_match_joints_and_limits(model):
    m = model
    for name in HIP_NAMES + WHEEL_NAMES:
        a = _id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
        j = _id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
        assert m.actuator_trnid[a][0] == j
        assert m.actuator_gear[a][0] == 1.0
        assert m.actuator_ctrllimited[a]
        limit = D.CG_TORQUE_LIMIT_NM if name in HIP_NAMES else WHEEL_TORQUE_LIMIT
        np.testing.assert_allclose(m.actuator_ctrlrange[a], [-limit, limit])
    assert m.nu == 6



def test_rotor_armature_matches_constants(model):
    """Each driven joint carries its motor's rotor reflected through the gear (kg m^2)."""
    m = model
    for name in HIP_NAMES + WHEEL_NAMES:
        j = _id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
        expected = HIP_ARMATURE if name in HIP_NAMES else WHEEL_ARMATURE
        assert m.dof_armature[m.jnt_dofadr[j]] == pytest.approx(expected, rel=1e-4), name

def test_hip_ranges_model_stop_and_sweep(model):
    """0 on the folded side (thigh on its stop), HIP_SWEEP off it, in the joint's sign."""
    m = model
    for j in C.JOINTS:
        jid = _id(m, mujoco.mjtObj.mjOBJ_JOINT, j.name)
        assert m.jnt_limited[jid]
        # off the stop, phi1 falls (front thigh swings down) and phi4 rises
        off_stop_phi = -1.0 if j.hip == "A" else +1.0
        q_off = off_stop_phi * j.sign * C.HIP_SWEEP
        np.testing.assert_allclose(sorted(m.jnt_range[jid]), sorted([0.0, q_off]), atol=1e-12)


def test_only_wheels_and_body_collide(model):
    m = model
    robot = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0]
    colliding = {m.geom(g).name for g in robot if m.geom_contype[g] or m.geom_conaffinity[g]}
    assert colliding == {"body_box", "left_wheel", "right_wheel"}
    # robot geoms never collide with each other, always with the floor
    floor = _id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    for g in robot:
        for h in robot:
            assert not (m.geom_contype[g] & m.geom_conaffinity[h])
    for g in robot:
        if m.geom(g).name in colliding:
            assert m.geom_contype[g] & m.geom_conaffinity[floor] or m.geom_contype[floor] & m.geom_conaffinity[g]


def test_imu_sensors_at_body_com(model):
    m = model
    s = _id(m, mujoco.mjtObj.mjOBJ_SITE, "imu")
    assert m.site_bodyid[s] == _body(m, "body")
    np.testing.assert_allclose(m.site_pos[s], 0.0, atol=1e-12)
    kinds = {m.sensor(i).name: m.sensor_type[i] for i in range(m.nsensor)}
    assert kinds["imu_quat"] == mujoco.mjtSensor.mjSENS_FRAMEQUAT
    assert kinds["imu_gyro"] == mujoco.mjtSensor.mjSENS_GYRO
    assert kinds["imu_accel"] == mujoco.mjtSensor.mjSENS_ACCELEROMETER


def test_options(model):
    assert model.opt.timestep == 0.001
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert model.neq == 2 and all(model.eq_type == mujoco.mjtEq.mjEQ_CONNECT)


# --- five-bar geometry and signs ------------------------------------------------------------
def _fivebar_point(m, d, world_point, leg):
    """(x_fb, y_fb) of a world point in ``leg``'s five-bar frame (origin at hip A)."""
    body = _body(m, "body")
    rel = d.xmat[body].reshape(3, 3).T @ (world_point - d.xpos[body])
    hip_a = m.body_pos[_body(m, f"{leg}_front_thigh")]
    return hip_a[0] - rel[0], hip_a[2] - rel[2]


def _leg_polar(m, d, leg):
    """(L0, phi0) of ``leg`` measured in the simulation (m, rad)."""
    c = d.site_xpos[_id(m, mujoco.mjtObj.mjOBJ_SITE, f"{leg}_front_c")]
    x, y = _fivebar_point(m, d, c, leg)
    return math.hypot(x - C.L5 / 2, y), math.atan2(y, x - C.L5 / 2)


def test_rest_pose_is_on_the_stops_and_closed(model):
    m = model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    rest = fivebar.forward_kinematics(C.PHI1_STOP, C.PHI4_STOP)
    for leg in LEGS:
        L0, phi0 = _leg_polar(m, d, leg)
        assert L0 == pytest.approx(rest.L0, abs=1e-9)
        assert phi0 == pytest.approx(rest.phi0, abs=1e-9)
    np.testing.assert_allclose(d.efc_pos[:d.nefc][d.efc_type[:d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY],
                               0.0, atol=1e-9)


@pytest.mark.parametrize("joint", C.JOINTS, ids=lambda j: j.name)
def test_shaft_sign_moves_phi_as_constants_say(model, joint):
    """phi = stop + sign * q: e.g. a positive left front shaft angle lowers phi1."""
    m = model
    d = mujoco.MjData(m)
    q = 0.3 if joint.sign * (-1 if joint.hip == "A" else 1) > 0 else -0.3  # a move off the stop
    d.qpos[m.jnt_qposadr[_id(m, mujoco.mjtObj.mjOBJ_JOINT, joint.name)]] = q
    mujoco.mj_kinematics(m, d)
    thigh = f"{joint.leg}_{'front' if joint.hip == 'A' else 'rear'}"
    hip = _fivebar_point(m, d, d.xpos[_body(m, f"{thigh}_thigh")], joint.leg)
    knee = _fivebar_point(m, d, d.xpos[_body(m, f"{thigh}_shin")], joint.leg)
    phi = math.atan2(knee[1] - hip[1], knee[0] - hip[0])
    assert phi == pytest.approx(joint.stop + joint.sign * q, abs=1e-9)


@pytest.mark.parametrize("wheel", C.WHEELS, ids=lambda w: w.name)
def test_positive_wheel_turn_rolls_as_constants_say(model, wheel):
    """Rolling without slip, the axle moves opposite to the wheel's lowest point."""
    m = model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    g = _id(m, mujoco.mjtObj.mjOBJ_GEOM, wheel.name)
    bottom = d.geom_xpos[g] - [0.0, 0.0, C.WHEEL_RADIUS]
    jacp = np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, jacp, None, bottom, _body(m, wheel.name))
    dof = m.jnt_dofadr[_id(m, mujoco.mjtObj.mjOBJ_JOINT, wheel.name)]
    bottom_speed_x = jacp[0, dof]  # m/s of the contact point per rad/s of the shaft
    assert bottom_speed_x == pytest.approx(-wheel.forward_sign * C.WHEEL_RADIUS, rel=1e-9)


def _random_hip_angles(rng, n):
    """n (phi1, phi4) pairs inside the hips' ranges that close the loop."""
    out = []
    while len(out) < n:
        phi1 = C.PHI1_STOP - rng.uniform(0.0, C.HIP_SWEEP)
        phi4 = C.PHI4_STOP + rng.uniform(0.0, C.HIP_SWEEP)
        try:
            k = fivebar.forward_kinematics(phi1, phi4)
        except ValueError:
            continue
        if abs(math.sin(k.phi3 - k.phi2)) > 0.2:  # keep clear of the shins-parallel singularity
            out.append((phi1, phi4))
    return out


def test_fivebar_geometry_matches_seed_forward_kinematics():
    """Hips driven to random angles in zero gravity; once the loop constraint has
    settled, the simulated hip-midpoint -> axle vector is the design document's (L0, phi0)."""
    phys = Physics()
    m, d = phys.model, phys.data
    m.opt.gravity[:] = 0.0
    rng = np.random.default_rng(3)
    for phi1, phi4 in _random_hip_angles(rng, 6):
        phys.reset_standing(0.17, drop_height_m=1.0)
        start = {n: phys.shaft_state(n)[0] for n in HIP_NAMES}
        goal = {j.name: fivebar.shaft_from_phi(j, phi1 if j.hip == "A" else phi4) for j in C.JOINTS}
        for i in range(800):  # ramp for 0.4 s, then hold
            s = min(1.0, i / 400)
            torques = {}
            for n in HIP_NAMES:
                q, w = phys.shaft_state(n)
                torques[n] = 60.0 * (start[n] + s * (goal[n] - start[n]) - q) - 0.6 * w
            phys.set_torques(torques, {})
            phys.step()
        mujoco.mj_forward(m, d)
        for n in HIP_NAMES:  # settled
            assert phys.shaft_state(n)[1] == pytest.approx(0.0, abs=1e-4)
        for leg in LEGS:
            q = {j.hip: phys.shaft_state(j.name)[0] for j in C.JOINTS if j.leg == leg}
            jnt = {j.hip: j for j in C.JOINTS if j.leg == leg}
            k = fivebar.forward_kinematics(fivebar.phi_from_shaft(jnt["A"], q["A"]),
                                           fivebar.phi_from_shaft(jnt["E"], q["E"]))
            L0, phi0 = _leg_polar(m, d, leg)
            assert L0 == pytest.approx(k.L0, abs=2e-5), (leg, phi1, phi4)
            assert phi0 == pytest.approx(k.phi0, abs=2e-4), (leg, phi1, phi4)
    assert phys.warnings() == {}


# --- every scene steps cleanly ------------------------------------------------------------
HALF_TRACK = C.HALF_TRACK
SCENES = {
    "flat": ((), dict(drop_height_m=0.05)),
    "step_up": ((TerrainFeature.step(x_m=0.12, height_m=0.05),), {}),
    "step_down": ((TerrainFeature.step(x_m=0.08, height_m=-0.1),), {}),
    "slope": ((TerrainFeature.slope(angle_rad=math.radians(15)),), dict(fit_legs_to_ground=True)),
    "ramp": ((TerrainFeature.ramp(x_m=-0.3, angle_rad=math.radians(10)),), {}),
    "bump_box": ((TerrainFeature.bump(x_m=0.0, y_m=HALF_TRACK, height_m=0.03),), dict(fit_legs_to_ground=True)),
    "bump_cylinder": ((TerrainFeature.bump(x_m=0.05, y_m=-HALF_TRACK, height_m=0.03, shape="cylinder"),), {}),
    "wall": ((TerrainFeature.wall(x_m=0.15, height_m=0.1),), {}),
    "projectile": ((TerrainFeature.projectile(0.5, 0.05, (-1.0, 0.0, 0.3), (5.0, 0.0, 1.0)),), {}),
}


@pytest.mark.parametrize("name", SCENES)
def test_scene_steps_a_second_without_warnings(name):
    """The robot stands (or drops) by each feature, hips held by a PD, pushed
    towards +x at 4 N for 1 s: it meets the feature, and MuJoCo never warns."""
    terrain, kwargs = SCENES[name]
    phys = Physics(terrain=terrain)
    phys.reset_standing(0.17, **kwargs)
    features = {mujoco.mj_name2id(phys.model, mujoco.mjtObj.mjOBJ_GEOM, n) for n in phys.terrain_names}
    goal = {n: phys.shaft_state(n)[0] for n in HIP_NAMES}
    phys.apply_body_force([4.0, 0.0, 0.0])
    touched = set()
    for _ in range(1000):
        torques = {}
        for n in HIP_NAMES:
            q, w = phys.shaft_state(n)
            torques[n] = 30.0 * (goal[n] - q) - 0.3 * w
        phys.set_torques(torques, {})
        phys.step()
        for g1, g2 in phys.data.contact.geom[:phys.data.ncon].tolist():
            if g1 in features or g2 in features:
                touched.add((g1, g2))
    assert phys.warnings() == {}
    assert touched or not features, "the robot never met the feature"
    truth = phys.ground_truth()
    assert all(math.isfinite(v) for v in truth.values())
    assert truth["z"] > 0.05  # nothing sank through the ground
    assert truth["left_wheel_clearance"] > -0.005 and truth["right_wheel_clearance"] > -0.005


def test_scene_without_terrain_is_robot_plus_floor(model):
    assert {model.body(i).name for i in range(model.nbody)} >= {"world", "body", "left_wheel", "right_wheel"}
    ground = [model.geom(g).name for g in range(model.ngeom) if model.geom_bodyid[g] == 0]
    assert ground == ["floor"]


def test_the_nominal_truth_is_what_the_controller_believes():
    """At the nominal values the description and the controller's constants agree (the LQR was
    designed for this robot); a plant override is then the only source of mismatch."""
    pairs = {"L1": D.L1_M, "L2": D.L2_M, "L3": D.L3_M, "L4": D.L4_M, "L5": D.L5_M,
             "WHEEL_RADIUS": D.WHEEL_RADIUS_M, "HALF_TRACK": D.HALF_TRACK_M, "PHI1_STOP": D.PHI1_STOP_RAD,
             "PHI4_STOP": D.PHI4_STOP_RAD, "HIP_SWEEP": D.HIP_SWEEP_RAD, "MASS_BODY": D.MASS_BODY_KG,
             "MASS_TOTAL": MASS_TOTAL, "MASS_WHEEL": D.MASS_WHEEL_KG, "CG_TORQUE_LIMIT": D.CG_TORQUE_LIMIT_NM,
             "CG_TORQUE_CONSTANT": D.CG_TORQUE_CONSTANT_NM_PER_A, "CG_GEAR": D.CG_GEAR,
             "CG_OVER_TEMP": D.CG_OVER_TEMP_C, "CG_WARN_TEMP": D.CG_WARN_TEMP_C, "M3508_GEAR": D.M3508_GEAR,
             "M3508_TORQUE_CONSTANT": D.M3508_TORQUE_CONSTANT_NM_PER_A, "GRAVITY": D.GRAVITY_M_S2,
             "M3508_NO_LOAD_SPEED": D.M3508_NO_LOAD_SPEED_RAD_S, "C620_CURRENT_LIMIT": D.C620_CURRENT_LIMIT_A}
    for name, truth in pairs.items():
        assert getattr(C, name) == pytest.approx(truth, rel=1e-12), name
    wiring = {(m.name, m.motor_id, m.leg, m.hip, m.sign) for m in D.HIP_MOTORS}
    assert wiring == {(j.name, j.motor_id, j.leg, j.hip, j.sign) for j in C.JOINTS}
    assert {(w.name, w.esc_id) for w in D.WHEEL_DRIVES} == {(w.name, w.esc_id) for w in C.WHEELS}
