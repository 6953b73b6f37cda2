"""The LQR gain table: model, fit, stability, signs, and that the committed table is current."""
import dataclasses
import math

import numpy as np
import pytest

from wheelleg.controller import constants as C
from wheelleg.controller import lqr
from wheelleg.controller import params as P

from sharing import same_fixture

# every test here reaches the design's sympy derivation (design._linearised_model, cached per
# process, ~1 s) or the fixtures built on it: on one xdist worker it is derived once, not on each
pytestmark = same_fixture("lqr design")

design = None  # wheelleg.controller.design.lqr, imported by _design_module below


@pytest.fixture(scope="module", autouse=True)
def _design_module():
    """The design module (sympy and scipy: ~0.5 s of imports) on the worker that runs these tests
    only; at module level every xdist worker imported it while collecting."""
    global design
    from wheelleg.controller.design import lqr as design  # noqa: PLC0415

SAMPLES = np.linspace(P.LEG_LENGTH_MIN, P.LEG_LENGTH_MAX, 200)


@pytest.fixture(scope="module")
def fresh_design():
    return design.design()


@pytest.fixture(scope="module")
def exact_gains():
    return np.array([design.gains(L0) for L0 in SAMPLES])


def fitted(L0: float) -> np.ndarray:
    return np.array(lqr.gain_matrix(L0))


def closed_loop(L0: float, dt: float = P.CONTROL_PERIOD):
    """(Aa, Ba, Aa - Ba K) of the augmented design model (9 states) with the fitted K."""
    aa, ba = design.augmented_model(*design.discretise(*design.continuous_model(L0), dt), dt)
    return aa, ba, aa - ba @ fitted(L0)


def augmented(*plant_state: float) -> np.ndarray:
    """A (9,) design state from the plant's six: no integral, no command in flight."""
    return np.concatenate([plant_state, np.zeros(3)])


def lagrangian_model(L0: float) -> tuple[np.ndarray, np.ndarray]:
    """A, B linearised upright from the Lagrangian, written independently of the design document.

    q = (x, theta, phi). Wheel CoM at height R, leg CoM at (x + L sin th,
    R + L cos th), body CoM at (x + (L+LM) sin th - l sin ph, R + (L+LM) cos th
    + l cos ph). theta turns about +y and phi about -y, the wheel rolls forward
    at xd/R about +y, so the power of the inputs is T (xd/R - thd) + Tp (thd + phd).
    """
    leg = design.leg_mass_properties(L0)
    L, LM = leg.L, leg.LM
    mw, mp, M = C.MASS_WHEEL, C.MASS_LEG, C.MASS_BODY / 2
    Iw, Ip, IM = C.WHEEL_INERTIA + C.WHEEL_ARMATURE, leg.Ip, C.BODY_INERTIA[1] / 2
    R, l, g = C.WHEEL_RADIUS, C.BODY_COM_ABOVE_HIP, C.GRAVITY
    H = L + LM
    mass = np.array([
        [mw + Iw / R**2 + mp + M, mp * L + M * H, -M * l],
        [mp * L + M * H, mp * L**2 + Ip + M * H**2, -M * H * l],
        [-M * l, -M * H * l, M * l**2 + IM],
    ])
    stiffness = np.diag([0.0, -g * (mp * L + M * H), -g * M * l])  # Hessian of the potential
    forces = np.array([[1 / R, 0.0], [-1.0, 1.0], [0.0, 1.0]])  # generalised forces of (T, Tp)
    acc_q = -np.linalg.solve(mass, stiffness)
    acc_u = np.linalg.solve(mass, forces)
    order = (1, 0, 2)  # state rows theta, x, phi <- q = (x, theta, phi)
    a, b = np.zeros((6, 6)), np.zeros((6, 2))
    for row, qi in enumerate(order):
        a[2 * row, 2 * row + 1] = 1.0
        for col, qj in enumerate(order):
            a[2 * row + 1, 2 * col] = acc_q[qi, qj]
        b[2 * row + 1] = acc_u[qi]
    return a, b


# --- the model --------------------------------------------------------------------------
@pytest.mark.parametrize("L0", [P.LEG_LENGTH_MIN, P.LEG_LENGTH_NOMINAL, P.LEG_LENGTH_MAX])
def test_seed_model_matches_an_independent_lagrangian(L0):
    a, b = design.continuous_model(L0)
    a_ref, b_ref = lagrangian_model(L0)
    np.testing.assert_allclose(a, a_ref, rtol=1e-9, atol=1e-9 * np.abs(a_ref).max())
    np.testing.assert_allclose(b, b_ref, rtol=1e-9, atol=1e-9 * np.abs(b_ref).max())


def test_leg_mass_properties_are_consistent():
    for L0 in (0.12, 0.17, 0.26):
        leg = design.leg_mass_properties(L0)
        assert leg.L + leg.LM == pytest.approx(L0)
        assert 0 < leg.L < L0 / 2  # the wheel motor at C pulls the CoM towards the wheel
        # a point mass at the CoM is a lower bound; the rods spread it further
        assert leg.Ip > 0
    assert design.leg_mass_properties(0.26).L > design.leg_mass_properties(0.12).L


@pytest.mark.parametrize("L0", [P.LEG_LENGTH_MIN, P.LEG_LENGTH_NOMINAL, P.LEG_LENGTH_MAX])
def test_acceleration_equilibrium_accelerates_steadily_in_the_lagrangian_model(L0):
    """Leaning theta with T and Tp of 1 m/s^2, the independent model gains 1 m/s^2 and
    keeps every angle and rate (at any speed: the speed enters no force)."""
    theta, t, tp = design.acceleration_equilibrium(L0)
    a, b = lagrangian_model(L0)
    rates = a @ np.array([theta, 0.0, 0.0, 0.7, 0.0, 0.0]) + b @ np.array([t, tp])
    np.testing.assert_allclose(rates, [0.0, 0.0, 0.7, 1.0, 0.0, 0.0], atol=1e-9)
    assert 0.1 < theta < 0.3  # rad per m/s^2: the wheel behind the hip, leaning into it


def test_the_chassis_lean_per_acceleration_is_the_models_at_the_nominal_length():
    lean = design.acceleration_equilibrium(P.LEG_LENGTH_NOMINAL)[0]
    assert P.LEAN_PER_ACCEL == pytest.approx(lean, rel=1e-3)


def test_open_loop_is_unstable():
    for L0 in (P.LEG_LENGTH_MIN, P.LEG_LENGTH_NOMINAL, P.LEG_LENGTH_MAX):
        a, b = design.continuous_model(L0)
        assert np.max(np.linalg.eigvals(a).real) > 1.0  # rad/s
        ad, _ = design.discretise(a, b, P.CONTROL_PERIOD)
        assert np.max(np.abs(np.linalg.eigvals(ad))) > 1.0


def test_zoh_matches_a_fine_euler_integration():
    a, b = design.continuous_model(P.LEG_LENGTH_NOMINAL)
    ad, bd = design.discretise(a, b, P.CONTROL_PERIOD)
    x, u = np.array([0.1, 0.0, 0.0, 0.2, -0.05, 0.0]), np.array([0.3, -0.2])
    steps = 20000
    h = P.CONTROL_PERIOD / steps
    y = x.copy()
    for _ in range(steps):
        y = y + h * (a @ y + b @ u)
    np.testing.assert_allclose(ad @ x + bd @ u, y, rtol=1e-3, atol=1e-6)


def test_dlqr_gain_is_optimal_for_its_riccati_solution():
    """K from design.dlqr satisfies the discrete Riccati equation's fixed point."""
    ad, bd = design.discretise(*design.continuous_model(0.2), P.CONTROL_PERIOD)
    q, r = np.diag(P.LQR_Q), np.diag(P.LQR_R)
    p = q.copy()
    for _ in range(200000):  # value iteration, independent of scipy's solver
        k = np.linalg.solve(r + bd.T @ p @ bd, bd.T @ p @ ad)
        p_next = q + ad.T @ p @ (ad - bd @ k)
        if np.max(np.abs(p_next - p)) < 1e-10 * np.max(np.abs(p)):
            break
        p = p_next
    np.testing.assert_allclose(design.dlqr(ad, bd, q, r), k, rtol=1e-5, atol=1e-6)


# --- the fitted table --------------------------------------------------------------------
@pytest.mark.slow
def test_fit_error_is_small(exact_gains):
    fit = np.array([fitted(L0) for L0 in SAMPLES])
    assert np.max(np.abs(fit - exact_gains)) / np.max(np.abs(exact_gains)) < 1e-3


def test_closed_loop_is_stable_over_the_whole_range():
    for L0 in SAMPLES:
        _, _, cl = closed_loop(L0)
        assert np.max(np.abs(np.linalg.eigvals(cl))) < 1.0, L0


@pytest.mark.slow
def test_committed_table_is_what_the_script_produces(fresh_design):
    table = design.load_table()
    assert design.table_matches(fresh_design, table) == []
    assert table.DT == P.CONTROL_PERIOD == lqr.DT
    np.testing.assert_allclose(fitted(0.17), design.evaluate_fit(fresh_design.coeffs, 0.17), rtol=design.TABLE_RTOL)


@pytest.mark.slow
def test_table_check_catches_a_stale_table(fresh_design, tmp_path, monkeypatch, capsys):
    stale = fresh_design.coeffs.copy()
    stale[1, 4, 3] *= 1.001  # Tp's phi gain, constant term
    bad = dataclasses.replace(fresh_design, coeffs=stale)
    path = tmp_path / "lqr_gains.py"
    path.write_text(design.render(bad))
    assert design.table_matches(fresh_design, design.load_table(path)) != []
    path.write_text(design.render(dataclasses.replace(fresh_design, arm_coeffs=fresh_design.arm_coeffs * 1.001)))
    assert any(p.startswith("ARM") for p in design.table_matches(fresh_design, design.load_table(path)))
    monkeypatch.setattr(design, "GAINS_PATH", path)
    # the fresh design --check compares with is the fixture's (the same call, ~1 s; the test above checks it)
    real_design = design.design
    monkeypatch.setattr(design, "design", lambda dt: fresh_design if dt == fresh_design.dt else real_design(dt))
    assert design.main(["--check"]) == 1
    assert "stale table" in capsys.readouterr().err
    path.write_text(design.render(fresh_design))
    assert design.main(["--check"]) == 0


def test_gain_matrix_clamps_and_rejects_nan():
    assert lqr.gain_matrix(0.05) == lqr.gain_matrix(lqr.L0_MIN)
    assert lqr.gain_matrix(0.5) == lqr.gain_matrix(lqr.L0_MAX)
    k = lqr.gain_matrix(0.17)
    assert len(k) == 2 and all(len(row) == len(lqr.GAIN_NAMES) == len(design.GAIN_NAMES) for row in k)
    assert lqr.GAIN_NAMES == design.GAIN_NAMES
    assert all(isinstance(v, float) for row in k for v in row)
    with pytest.raises(ValueError):
        lqr.gain_matrix(float("nan"))


# --- signs ------------------------------------------------------------------------------
def test_forward_lean_is_caught_by_driving_the_wheel_forward():
    """theta0 = 0.1 rad: wheel behind the hip, i.e. the leg (and the robot on it)
    leans FORWARD with the body level. Open loop it falls further forward; the
    closed loop rolls the wheel forward under the hip first, then settles."""
    ad, bd, cl = closed_loop(P.LEG_LENGTH_NOMINAL)
    x0 = augmented(0.1, 0.0, 0.0, 0.0, 0.0, 0.0)
    falling = x0
    for _ in range(50):
        falling = ad @ falling
    assert falling[0] > 0.1  # theta grows: it falls the way it leans
    u0 = -fitted(P.LEG_LENGTH_NOMINAL) @ x0
    assert u0[0] > 0  # forward-rolling wheel torque
    xs = [x0]
    for _ in range(int(10.0 / P.CONTROL_PERIOD)):
        xs.append(cl @ xs[-1])
    xs = np.array(xs)
    assert xs[2, 3] > 0  # wheel speed: forward as soon as the command acts (one period late)
    first_move = xs[np.argmax(np.abs(xs[:, 2]) > 1e-3), 2]
    assert first_move > 0  # the wheel's first excursion is forward
    assert np.max(np.abs(xs[-1])) < 1e-3 * 0.1  # back to upright, at rest
    assert np.max(np.abs(xs[:, 0])) < 0.2  # without falling over first


def test_nose_up_body_gets_a_nose_down_hip_torque():
    k = fitted(P.LEG_LENGTH_NOMINAL)
    u = -k @ augmented(0.0, 0.0, 0.0, 0.0, 0.05, 0.0)
    assert u[1] < 0  # Tp's reaction on the body drives phi negative


def test_position_error_drives_the_wheel_back():
    """Ahead of the set point (x - x_ref > 0) the robot must end up going back:
    the closed loop from a pure position offset returns x to 0 without overshooting
    by more than the offset itself."""
    _, _, cl = closed_loop(P.LEG_LENGTH_NOMINAL)
    s = augmented(0.0, 0.0, 0.1, 0.0, 0.0, 0.0)
    xs = [s]
    for _ in range(int(10.0 / P.CONTROL_PERIOD)):
        xs.append(cl @ xs[-1])
    xs = np.array(xs)
    assert abs(xs[-1, 2]) < 1e-3
    assert np.min(xs[:, 2]) > -0.1
    assert math.isclose(xs[0, 2], 0.1)


# --- the augmented design: integral and delay -----------------------------------------------
def test_augmented_model_delays_the_command_and_integrates_the_position():
    ad, bd = design.discretise(*design.continuous_model(P.LEG_LENGTH_NOMINAL), P.CONTROL_PERIOD)
    aa, ba = design.augmented_model(ad, bd, P.CONTROL_PERIOD)
    s = augmented(0.01, 0.0, 0.2, 0.1, 0.0, 0.0)
    u = np.array([0.5, -0.3])
    nxt = aa @ s + ba @ u
    np.testing.assert_allclose(nxt[:6], ad @ s[:6])  # this period's command does not act yet
    np.testing.assert_allclose(nxt[7:], u)  # it is remembered for the next period
    assert nxt[6] == pytest.approx(0.2 * P.CONTROL_PERIOD)  # ix integrates the position
    after = aa @ nxt
    np.testing.assert_allclose(after[:6], ad @ nxt[:6] + bd @ u)


def test_gains_hold_with_one_period_of_real_delay():
    """The closed loop of the plant with a command that really acts one period late is
    stable at every leg length (the undelayed design of before was not designed for it)."""
    for L0 in SAMPLES[::20]:
        _, _, cl = closed_loop(L0)
        assert np.max(np.abs(np.linalg.eigvals(cl))) < 1.0, L0


def test_integral_removes_a_constant_disturbance():
    """A constant torque on the body (the CoM off the axle) leaves no position error."""
    ad, bd = design.discretise(*design.continuous_model(P.LEG_LENGTH_NOMINAL), P.CONTROL_PERIOD)
    aa, ba, cl = closed_loop(P.LEG_LENGTH_NOMINAL)
    disturbance = np.zeros(9)
    disturbance[:6] = bd @ np.array([0.0, 0.3])  # as if the hip pushed 0.3 N m all the time
    s = np.zeros(9)
    for _ in range(int(20.0 / P.CONTROL_PERIOD)):
        s = cl @ s + disturbance
    assert abs(s[2]) < 1e-3  # back at its spot
    assert abs(s[6]) > 1e-3  # held by the integral
