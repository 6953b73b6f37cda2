"""The balancer's LQR gains from its model: ``python -m wheelleg_balancer.design`` writes gains.py.

The linearised inverted pendulum on wheels, state s = (x, v, theta, omega):
axle position (m) and speed (m/s) forward, body pitch (rad, nose down +) and
its rate (rad/s); input u = the two wheels' torque summed (N m, rolling
forward +). From Lagrange's equations about the upright pose, with the
wheels' and rotors' inertia lumped (the rotor turns with the wheel relative
to the body; the lumping is the design's approximation):

    (m_w + I_w / r^2 + m) x'' + m l theta''          = u / r
    m l x''                + (I_b + m l^2) theta'' - m g l theta = -u

Discrete LQR at the control period (zero-order hold: the torque a tick commands
is held for the period), Bryson's rule: Q weights 1/max^2 of 0.1 m, 0.5 m/s,
0.05 rad, 2 rad/s, R 1/(3 N m)^2; a continuous design put a pole at -930 rad/s,
which a 2 ms loop cannot follow. ``main`` refuses gains whose loop with one period
of delay (a tick's feedback answers the command before) is not stable. Needs
scipy (a design-time tool, not the robot's program).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from wheelleg_balancer import constants as C
from wheelleg_balancer import params as P

Q_MAX = (0.1, 0.5, 0.05, 2.0)  # Bryson: the largest acceptable error of each state
U_MAX_NM = 3.0
GAINS_PATH = Path(__file__).resolve().parent / "gains.py"


def model() -> tuple[np.ndarray, np.ndarray]:
    """(A (4, 4), B (4, 1)) of s' = A s + B u, from constants.py."""
    m, l, r, g = C.BODY_MASS_KG, C.COM_OVER_AXLE_M, C.WHEEL_RADIUS_M, C.GRAVITY_M_S2
    wheels = 2 * C.WHEEL_MASS_KG
    inertia = 2 * (C.WHEEL_INERTIA_KG_M2 + C.ROTOR_INERTIA_KG_M2 * C.M3508_GEAR ** 2)
    mass = np.array([[wheels + inertia / r ** 2 + m, m * l], [m * l, C.BODY_PITCH_INERTIA_KG_M2 + m * l * l]])
    inv = np.linalg.inv(mass)
    gravity = inv @ np.array([0.0, m * g * l])  # (x'', theta'') per rad of theta
    drive = inv @ np.array([1.0 / r, -1.0])  # (x'', theta'') per N m of u
    a = np.zeros((4, 4))
    a[0, 1] = a[2, 3] = 1.0
    a[1, 2], a[3, 2] = gravity
    b = np.array([[0.0], [drive[0]], [0.0], [drive[1]]])
    return a, b


def discrete(period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(Ad (4, 4), Bd (4, 1)): ``model`` over one period with the input held (zero-order hold)."""
    from scipy.linalg import expm  # noqa: PLC0415 (design time only)

    a, b = model()
    block = np.zeros((5, 5))
    block[:4, :4], block[:4, 4:] = a * period_s, b * period_s
    held = expm(block)
    return held[:4, :4], held[:4, 4:]


def lqr_gains(period_s: float = P.CONTROL_PERIOD) -> np.ndarray:
    """K (4,): u_k = -K s_k minimises the sum of s'Qs + u'Ru over ticks of ``period_s``."""
    from scipy.linalg import solve_discrete_are  # noqa: PLC0415 (design time only)

    ad, bd = discrete(period_s)
    q = np.diag([1.0 / v ** 2 for v in Q_MAX])
    r = np.array([[1.0 / U_MAX_NM ** 2]])
    p = solve_discrete_are(ad, bd, q, r)
    return np.linalg.solve(r + bd.T @ p @ bd, bd.T @ p @ ad).ravel()


def delayed_loop_radius(k: np.ndarray, period_s: float = P.CONTROL_PERIOD) -> float:
    """Spectral radius of the closed loop when each tick's torque comes one period late (< 1: stable)."""
    ad, bd = discrete(period_s)
    loop = np.zeros((5, 5))
    loop[:4, :4], loop[:4, 4:], loop[4, :4] = ad, bd, -k
    return float(np.max(np.abs(np.linalg.eigvals(loop))))


def gains_text(k: np.ndarray) -> str:
    values = ", ".join(repr(round(float(v), 6)) for v in k)
    return (f'"""LQR gains of the balancer, written by ``python -m wheelleg_balancer.design`` (do not edit).\n\n'
            f"u = -K . (x - x_ref, v - v_ref, pitch, pitch rate): the wheels' summed torque (N m) from the axle's\n"
            f"position (m) and speed (m/s) errors and the body's pitch (rad, nose down +) and its rate (rad/s).\n"
            f'"""\nK = ({values})\n')


def main() -> int:
    k = lqr_gains()
    radius = delayed_loop_radius(k)
    if not radius < 1.0:
        print(f"design: the loop with one period of delay is unstable (radius {radius:.4f})", file=sys.stderr)
        return 1
    GAINS_PATH.write_text(gains_text(k))
    print(f"wrote {GAINS_PATH}: K = {np.round(k, 3)}; with one period of delay the loop's radius is {radius:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
