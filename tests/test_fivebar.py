"""Five-bar kinematics and VMC against independent constructions.

The references here do not reuse wheelleg.controller.fivebar: a second team's construction
by perpendicular bisector, central finite differences of the leg geometry,
and statics by virtual work on point coordinates.
"""
import math

import numpy as np
import pytest

from wheelleg.controller import constants as C
from wheelleg.controller import fivebar as fb

RNG_SEED = 20240611


def working_poses(n: int = 300) -> list[tuple[float, float]]:
    """(phi1, phi4) over the working range: L0 0.105..0.275 m, leg +-0.6 rad off vertical."""
    rng = np.random.default_rng(RNG_SEED)
    poses = []
    while len(poses) < n:
        L0, phi0 = rng.uniform(0.105, 0.275), math.pi / 2 + rng.uniform(-0.6, 0.6)
        try:
            poses.append(fb.inverse_kinematics(L0, phi0))
        except ValueError:  # a corner of the box the leg cannot reach
            continue
    return poses


def random_angle_poses(n: int = 300) -> list[tuple[float, float]]:
    """(phi1, phi4) drawn straight from the hips' sweeps, kept where that construction closes the loop."""
    rng = np.random.default_rng(RNG_SEED + 1)
    poses = []
    while len(poses) < n:
        phi1 = C.PHI1_STOP - rng.uniform(0.0, C.HIP_SWEEP)
        phi4 = C.PHI4_STOP + rng.uniform(0.0, C.HIP_SWEEP)
        if _seed001(phi1, phi4) is not None:
            poses.append((phi1, phi4))
    return poses


def _seed001(phi1: float, phi4: float):
    """The second team's forward kinematics, in its own frame, mapped back to the five-bar frame.

    001: origin O at the middle of the hips, motors at -+ld/2, thighs lt, shins
    ll; knees C, D; the wheel E = F + l_FE * rot(CD)/|CD| with F the middle of
    CD and l_FE = sqrt(ll^2 - CD^2/4); angles about +y from x, so a point at
    angle a is (cos a, -sin a) in (x, z). Mapping x001 = x_fb - L5/2,
    z001 = -y_fb makes 001's thigh angles equal to phi1, phi4.
    Returns (L0, phi0, B, C, D) in the five-bar frame, or None when 001's
    construction does not close.
    """
    ld, lt, ll = C.L5, C.L1, C.L2
    knee_front = np.array([-ld / 2 + lt * math.cos(phi1), -lt * math.sin(phi1)])
    knee_rear = np.array([ld / 2 + lt * math.cos(phi4), -lt * math.sin(phi4)])
    cd = knee_rear - knee_front
    half_sq = ll * ll - cd @ cd / 4
    if half_sq <= 0:
        return None
    fe = math.sqrt(half_sq) / math.sqrt(cd @ cd) * np.array([cd[1], -cd[0]])
    wheel = (knee_front + knee_rear) / 2 + fe
    h, psi = math.hypot(*wheel), math.atan2(wheel[1], wheel[0])

    def to_fb(p):
        return np.array([p[0] + ld / 2, -p[1]])

    return h, -psi, to_fb(knee_front), to_fb(wheel), to_fb(knee_rear)


def _l0_phi0(q) -> np.ndarray:
    k = fb.forward_kinematics(*q)
    return np.array([k.L0, k.phi0])


def _numeric_jacobian(fun, q, h=1e-6) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    cols = []
    for i in range(len(q)):
        dq = np.zeros_like(q)
        dq[i] = h
        cols.append((np.asarray(fun(q + dq)) - np.asarray(fun(q - dq))) / (2 * h))
    return np.array(cols).T


# --- forward kinematics ------------------------------------------------------------
@pytest.mark.parametrize("poses", [working_poses, random_angle_poses], ids=["from-leg-box", "from-hip-sweeps"])
def test_forward_kinematics_matches_seed_001(poses):
    for phi1, phi4 in poses():
        k = fb.forward_kinematics(phi1, phi4)
        L0, phi0, b, c, d = _seed001(phi1, phi4)
        assert k.L0 == pytest.approx(L0, abs=1e-12)
        assert k.phi0 == pytest.approx(phi0, abs=1e-10)
        np.testing.assert_allclose(k.B, b, atol=1e-12)
        np.testing.assert_allclose(k.C, c, atol=1e-12)
        np.testing.assert_allclose(k.D, d, atol=1e-12)
        # the links keep their lengths and C lies below both knees
        assert math.dist(k.B, k.C) == pytest.approx(C.L2, abs=1e-12)
        assert math.dist(k.D, k.C) == pytest.approx(C.L3, abs=1e-12)
        assert k.C[1] > max(k.B[1], k.D[1])
        assert k.C == pytest.approx((k.B[0] + C.L2 * math.cos(k.phi2), k.B[1] + C.L2 * math.sin(k.phi2)))
        assert k.C == pytest.approx((k.D[0] + C.L3 * math.cos(k.phi3), k.D[1] + C.L3 * math.sin(k.phi3)))


def test_mechanical_stop_is_the_shortest_leg():
    k = fb.forward_kinematics(C.PHI1_STOP, C.PHI4_STOP)
    assert k.L0 == pytest.approx(0.104, abs=0.001)
    assert k.phi0 == pytest.approx(math.pi / 2, abs=1e-9)  # symmetric: straight down


def test_symmetric_hips_give_a_vertical_leg_and_leg_angle_follows_the_hips():
    k = fb.forward_kinematics(math.pi - 0.6, 0.6)
    assert k.phi0 == pytest.approx(math.pi / 2, abs=1e-12)
    # turning both hips the same way swings the leg that way (phi0 grows with phi1 and phi4)
    swung = fb.forward_kinematics(math.pi - 0.6 + 0.05, 0.6 + 0.05)
    assert swung.phi0 > k.phi0 + 0.03


def test_forward_kinematics_rejects_non_finite_angles():
    # (With L2 + L3 > L1 + L4 + L5 every pair of finite hip angles closes the loop.)
    with pytest.raises(ValueError, match="finite"):
        fb.forward_kinematics(float("nan"), 0.3)
    with pytest.raises(ValueError, match="finite"):
        fb.forward_kinematics(2.9, float("inf"))


# --- Jacobian and velocities ---------------------------------------------------------
def test_closed_form_jacobian_matches_central_differences():
    for q in working_poses(200) + random_angle_poses(100):
        k = fb.forward_kinematics(*q)
        numeric = _numeric_jacobian(_l0_phi0, q)
        np.testing.assert_allclose(fb.jacobian(k), numeric, rtol=1e-6, atol=1e-8)


def test_leg_velocity_is_the_time_derivative_along_a_path():
    rng = np.random.default_rng(RNG_SEED + 2)
    for q in working_poses(50):
        rate = rng.uniform(-3, 3, size=2)
        k = fb.forward_kinematics(*q)
        along = _numeric_jacobian(lambda t: _l0_phi0(np.asarray(q) + t[0] * rate), [0.0])[:, 0]
        np.testing.assert_allclose(fb.leg_velocity(k, *rate), along, rtol=1e-6, atol=1e-8)


# --- VMC -------------------------------------------------------------------------------
def test_virtual_work_fixes_the_signs_of_F_and_Tp():
    """T1 dphi1 + T4 dphi4 = F dL0 + Tp (dtheta + dphi), with theta = pi/2 - phi0 - phi."""
    rng = np.random.default_rng(RNG_SEED + 3)
    for q in working_poses(100):
        k = fb.forward_kinematics(*q)
        F, Tp = rng.uniform(-100, 100), rng.uniform(-5, 5)
        dq = rng.uniform(-1e-6, 1e-6, size=2)
        dphi_body = rng.uniform(-1e-6, 1e-6)  # the body pitching changes theta but not the hips
        before, after = _l0_phi0(q), _l0_phi0(np.asarray(q) + dq)
        d_l0 = after[0] - before[0]
        d_theta = -(after[1] - before[1]) - dphi_body
        t1, t4 = fb.joint_torques(k, F, Tp)
        work_hips = t1 * dq[0] + t4 * dq[1]
        work_leg = F * d_l0 + Tp * (d_theta + dphi_body)
        assert work_hips == pytest.approx(work_leg, rel=1e-4, abs=1e-12)


def test_positive_F_extends_and_positive_Tp_swings_the_wheel_back():
    k = fb.forward_kinematics(*fb.inverse_kinematics(0.17, math.pi / 2))
    t1, t4 = fb.joint_torques(k, 10.0, 0.0)
    assert fb.leg_velocity(k, t1, t4)[0] > 0  # moving along the torques lengthens the leg
    t1, t4 = fb.joint_torques(k, 0.0, 1.0)
    dphi0 = fb.leg_velocity(k, t1, t4)[1]
    assert dphi0 < 0  # theta = pi/2 - phi0 - phi grows: the wheel goes back (to +x_fb)
    assert fb.forward_kinematics(k.phi1 + 1e-3 * t1, k.phi4 + 1e-3 * t4).C[0] > k.C[0]


def test_joint_torques_and_leg_force_are_inverse():
    rng = np.random.default_rng(RNG_SEED + 4)
    for q in working_poses(200):
        k = fb.forward_kinematics(*q)
        F, Tp = rng.uniform(-150, 150), rng.uniform(-8, 8)
        assert fb.leg_force(k, *fb.joint_torques(k, F, Tp)) == pytest.approx((F, Tp), rel=1e-9, abs=1e-9)
        t1, t4 = rng.uniform(-12, 12, size=2)
        assert fb.joint_torques(k, *fb.leg_force(k, t1, t4)) == pytest.approx((t1, t4), rel=1e-9, abs=1e-9)


def _world_to_fb(vec_world, pitch_up: float) -> np.ndarray:
    """(forward, up) world vector into the body-fixed five-bar frame; body pitched nose-up."""
    back, down = -vec_world[0], -vec_world[1]  # five-bar axes of a level body
    c, s = math.cos(pitch_up), math.sin(pitch_up)  # five-bar angles grow nose-up: rotate by -pitch
    return np.array([c * back + s * down, -s * back + c * down])


@pytest.mark.parametrize("pitch_up", [0.0, 0.15, -0.2])
def test_statics_support_force_of_a_massless_leg(pitch_up):
    """A ground force on the wheel, held by hip torques from the point Jacobian of C.

    leg_force then support_force (no masses, at rest) must give the vertical
    part of the ground force back, for a leg off vertical (tests P's Tp sign).
    """
    rng = np.random.default_rng(RNG_SEED + 5)
    for q in working_poses(60):
        k = fb.forward_kinematics(*q)
        ground = np.array([rng.uniform(-10, 10), rng.uniform(5, 40)])  # N on the wheel: forward, up
        ground_fb = _world_to_fb(ground, pitch_up)
        point_jac = _numeric_jacobian(lambda qq: fb.forward_kinematics(*qq).C, q)  # dC/dq (2, 2)
        t1, t4 = -point_jac.T @ ground_fb  # hip torques that balance it (virtual work)
        F, Tp = fb.leg_force(k, t1, t4)
        theta = math.pi / 2 - k.phi0 - pitch_up
        fn = fb.support_force(F, Tp, theta, k.L0, 0.0, 0.0, 0.0, 0.0, 0.0, axle_mass=0.0)
        assert fn == pytest.approx(ground[1], rel=1e-5)


def test_support_force_in_static_stance_is_half_the_robot_weight():
    """Hip torques from virtual work with the real link masses; Fn ~ (MASS_TOTAL/2) g."""
    weight_half = C.MASS_TOTAL / 2 * C.GRAVITY
    wheel_side = C.MASS_WHEEL + C.MASS_WHEEL_MOTOR  # point masses at C

    def heights(q):  # sum of m_link * y_fb of the link centres (kg m), and y_fb of C (m)
        k = fb.forward_kinematics(*q)
        thighs = (k.B[1] + k.D[1]) / 2 * C.MASS_LINK_THIGH
        shins = (k.B[1] + k.C[1] + k.D[1] + k.C[1]) / 2 * C.MASS_LINK_SHIN
        return np.array([thighs + shins, k.C[1]])

    for L0 in np.linspace(0.12, 0.26, 8):
        q = fb.inverse_kinematics(L0, math.pi / 2)
        k = fb.forward_kinematics(*q)
        d_mass_y, d_c_y = _numeric_jacobian(heights, q)
        # y_fb is down: ground pushes -y at C, gravity +y on every mass
        torques = (weight_half - wheel_side * C.GRAVITY) * d_c_y - C.GRAVITY * d_mass_y
        F, Tp = fb.leg_force(k, *torques)
        assert 12.0 < F < weight_half  # the leg pushes, and carries less than the wheel does
        fn = fb.support_force(F, Tp, 0.0, k.L0, 0.0, 0.0, 0.0, 0.0, 0.0)
        assert fn == pytest.approx(weight_half, rel=0.02)


def test_support_force_dynamic_terms_follow_the_wheel_height():
    """m (g + zdd_w) with zdd_w the second derivative of z_hip - L0 cos(theta)."""
    def wheel_z(t):  # hip accelerating up at 1.5 m/s^2, leg lengthening and swinging
        L0, theta = 0.17 + 0.03 * t + 0.2 * t * t, 0.1 + 0.8 * t - 1.1 * t * t
        return 0.75 * t * t - L0 * math.cos(theta)

    h = 1e-4
    zdd = (wheel_z(h) - 2 * wheel_z(0.0) + wheel_z(-h)) / h**2
    fn = fb.support_force(0.0, 0.0, 0.1, 0.17, 0.03, 0.4, 0.8, -2.2, 1.5, axle_mass=1.0)
    assert fn == pytest.approx(C.GRAVITY + zdd, rel=1e-5)


# --- inverse kinematics ------------------------------------------------------------------
def test_inverse_kinematics_round_trip():
    rng = np.random.default_rng(RNG_SEED + 6)
    for _ in range(300):
        L0, phi0 = rng.uniform(0.105, 0.26), math.pi / 2 + rng.uniform(-0.4, 0.4)
        phi1, phi4 = fb.inverse_kinematics(L0, phi0)
        k = fb.forward_kinematics(phi1, phi4)
        assert (k.L0, k.phi0) == pytest.approx((L0, phi0), abs=1e-10)
        assert k.B[0] < k.C[0] < k.D[0]  # knees outward: front knee ahead, rear knee behind
    for phi1, phi4 in random_angle_poses(200):
        k = fb.forward_kinematics(phi1, phi4)
        assert fb.inverse_kinematics(k.L0, k.phi0) == pytest.approx((phi1, phi4), abs=1e-9)


def test_inverse_kinematics_rejects_unreachable_points():
    with pytest.raises(ValueError, match="reach"):
        fb.inverse_kinematics(0.30, math.pi / 2)  # beyond the full stretch
    with pytest.raises(ValueError, match="reach"):
        fb.inverse_kinematics(0.02, math.pi / 2)


# --- hip motor shafts ------------------------------------------------------------------
def test_shaft_mapping_round_trip_and_zero_at_the_stop():
    for joint in C.JOINTS:
        assert fb.phi_from_shaft(joint, 0.0) == joint.stop
        for q in (-0.7, 0.0, 0.3, 1.2):
            assert fb.shaft_from_phi(joint, fb.phi_from_shaft(joint, q)) == pytest.approx(q)


def test_left_shaft_turning_positive_lowers_phi_right_raises_it():
    for joint in C.JOINTS:
        moved = fb.phi_from_shaft(joint, 0.1)
        assert (moved < joint.stop) if joint.leg == "left" else (moved > joint.stop)
        assert fb.phi_rate_from_shaft(joint, 2.0) == pytest.approx((moved - joint.stop) / 0.05)


def test_shaft_torque_does_the_same_work_as_the_joint_torque():
    for joint in C.JOINTS:
        T, dq = 1.7, 1e-3
        dphi = fb.phi_from_shaft(joint, 0.4 + dq) - fb.phi_from_shaft(joint, 0.4)
        assert fb.shaft_torque(joint, T) * dq == pytest.approx(T * dphi)
        assert fb.phi_torque_from_shaft(joint, fb.shaft_torque(joint, T)) == pytest.approx(T)


def test_standing_torques_lift_the_body_on_both_sides():
    """The static leg push needs the front thigh driven down (phi1 decreasing) and the
    rear one down (phi4 increasing); on the left leg that is a positive then a negative shaft torque."""
    k = fb.forward_kinematics(*fb.inverse_kinematics(0.17, math.pi / 2))
    t1, t4 = fb.joint_torques(k, 17.0, 0.0)
    assert t1 < 0 < t4
    assert t4 == pytest.approx(-t1)  # symmetric pose
    front, rear = (j for j in C.JOINTS if j.leg == "left")
    assert fb.shaft_torque(front, t1) > 0 > fb.shaft_torque(rear, t4)
    assert 1.0 < abs(t1) < 2.0  # docs/robot.md: ~1.4 N m per motor at 17 N
