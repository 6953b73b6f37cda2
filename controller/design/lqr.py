"""Design the LQR gain table K(L0) and write controller/lqr_gains.py (and the firmware's copy).

    python -m wheelleg.controller.design.lqr [--dt S] [--check]

The wheel-legged pendulum of the design document, (1.1)-(1.9) as the public
controllers write them (docs/control.md; the document's own (1.8)/(1.9) have
cos/sin(theta) where phi belongs),
with this robot's numbers from controller/constants.py:

  plant state x = [theta, dtheta, x, dx, phi, dphi]   (rad, rad/s, m, m/s, rad, rad/s)
  input u = [T, Tp]                                   (N m, N m)

The gains are designed on the plant augmented with two things real robots need
(``augmented_model``):

  s = [x, ix, T_prev, Tp_prev],  u = -K (s - s_ref),  K of shape (2, 9)

  ix        integral of the position error (m s): a constant disturbance (the
            CoM off the axis, an IMU mounted tilted) would otherwise need a
            standing position error to hold it, and past the controller's
            position-error clamp that becomes a creep
  T_prev,   the command sent one control period earlier: the design assumes
  Tp_prev   each command acts one period after it is computed (CAN transit,
            the drives' own loops), so a period of actuation or feedback delay
            is inside the model instead of eating the phase margin

  theta  virtual leg from vertical, > 0 with the wheel behind the hip
  x      wheel travel, forward positive
  phi    body pitch, nose up positive (= -pitch of the body frame)
  T      wheel motor torque on ONE wheel, positive rolls it forward (its
         reaction on the leg is -T in theta)
  Tp     virtual hip torque on ONE leg from the body, positive drives theta
         positive (its reaction drives phi positive); fivebar.joint_torques
         maps it to the hips

Per-side model (the convention of Skythinker/LJW0401): one leg, one wheel and
half the body, M = MASS_BODY/2 and I_M = Iyy(body)/2, so T and Tp are per
wheel and per leg, and Q, R weight per-side quantities. Leg CoM distances
L (from the wheel axle), LM (from the hip) and the leg inertia Ip about its
CoM come from the five-bar's mass split at each L0 (``leg_mass_properties``).

The accelerations appear linearly, so sympy's linear_eq_to_matrix gives
M(q) qdd = b(q, qd, u); at the upright equilibrium qdd = 0, hence
d(qdd)/dx = M0^-1 db/dx and d(qdd)/du = M0^-1 db/du (docs/control.md).
Exact zero-order-hold discretisation at dt, discrete LQR by
scipy.linalg.solve_discrete_are, each of the 12 gains fitted as a cubic in L0.
"""
from __future__ import annotations

import argparse
import functools
import math
import re
import sys
import types
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.linalg
import sympy as sp

from wheelleg.controller import constants as C
from wheelleg.controller import fivebar
from wheelleg.controller import params as P

GAINS_PATH = Path(__file__).resolve().parent.parent / "lqr_gains.py"
# the firmware's copy of the same table (firmware/, docs/firmware.md): rendered from GAINS_PATH's
# numbers, so the C program evaluates exactly the Python program's fit
C_GAINS_PATH = Path(__file__).resolve().parents[2] / "firmware" / "app" / "lqr_gains.c"
FIT_ORDER = 3
FIT_SAMPLES = 200  # L0 samples on which the fit error is measured
STATE_NAMES = ("theta", "dtheta", "x", "dx", "phi", "dphi")  # the plant's
GAIN_NAMES = STATE_NAMES + ("ix", "T_prev", "Tp_prev")  # the augmented state the gains multiply
INPUT_NAMES = ("T", "Tp")
# per-side body (see the module docstring)
BODY_MASS_SIDE = C.MASS_BODY / 2  # kg
WHEEL_SPIN_INERTIA = C.WHEEL_INERTIA + C.WHEEL_ARMATURE  # kg m^2: wheel plus the M3508 rotor reflected (it spins with the wheel)
BODY_PITCH_INERTIA_SIDE = C.BODY_INERTIA[1] / 2  # kg m^2


# --- leg mass distribution ------------------------------------------------------
@dataclass(frozen=True)
class LegMass:
    """The leg as the model's rigid pendulum at one L0 (m, kg m^2)."""

    L: float  # leg CoM to wheel axle, along the virtual leg
    LM: float  # leg CoM to hip (midpoint of AE), along the virtual leg
    Ip: float  # pitch inertia about the leg CoM


def leg_mass_properties(L0: float) -> LegMass:
    """L, LM, Ip of one leg posed symmetrically (phi0 = pi/2) at length L0 (m).

    Links are uniform rods (inertia m l^2/12 about their middle), the wheel
    motor a point mass at C (its own spin inertia, ~1e-4 kg m^2, is left out).
    The combined CoM is projected on the virtual leg; by symmetry it lies on it.
    """
    k = fivebar.forward_kinematics(*fivebar.inverse_kinematics(L0, math.pi / 2))
    a, e = (0.0, 0.0), (C.L5, 0.0)
    rods = ((C.MASS_LINK_THIGH, a, k.B, C.L1), (C.MASS_LINK_SHIN, k.B, k.C, C.L2),
            (C.MASS_LINK_THIGH, e, k.D, C.L4), (C.MASS_LINK_SHIN, k.D, k.C, C.L3))
    parts = [(m, np.add(p, q) / 2, m * length**2 / 12) for m, p, q, length in rods]
    parts.append((C.MASS_WHEEL_MOTOR, np.array(k.C), 0.0))
    mass = sum(m for m, _, _ in parts)
    com = sum(m * r for m, r, _ in parts) / mass
    ip = sum(i + m * float(np.dot(r - com, r - com)) for m, r, i in parts)
    hip = np.array((C.L5 / 2, 0.0))
    axis = (np.array(k.C) - hip) / k.L0
    lm = float(np.dot(com - hip, axis))
    return LegMass(L=L0 - lm, LM=lm, Ip=ip)


def static_arm(L0: float) -> float:
    """g (M L0 + m_p L) (N m per unit sin theta) of one side at leg length L0 (m).

    Standing still (no acceleration, T = 0, phi = 0), the leg's moment balance (1.6)
    about the wheel axle reads (Pf L + Pm LM) sin(theta) + Tp = 0 with Pm = M g and
    Pf = (M + m_p) g, so the hip torque Tp that holds a body whose CoM sits off the hip
    goes with the leg angle that puts the whole CoM over the axle:
    sin(theta) = -Tp / static_arm(L0). The controller's balance point (controller/lqr.py
    ``balance_lean``) is this relation, fitted.
    """
    leg = leg_mass_properties(L0)
    return C.GRAVITY * ((BODY_MASS_SIDE + C.MASS_LEG) * leg.L + BODY_MASS_SIDE * leg.LM)


# --- the symbolic model -----------------------------------------------------------
@functools.lru_cache(maxsize=1)
def _linearised_model():
    """Lambdified (M0, db/dx, db/du) of the pendulum at the upright equilibrium.

    Arguments of each function: (L, LM, Ip) of the leg; the rest is constants.
    """
    th, dth, x, dx, ph, dph = sp.symbols("theta dtheta x dx phi dphi")
    ddth, ddx, ddph = sp.symbols("ddtheta ddx ddphi")
    T, Tp = sp.symbols("T Tp")
    L, LM, Ip = sp.symbols("L L_M I_p", positive=True)
    R, l, mw, mp, M, Iw, IM, g = (C.WHEEL_RADIUS, C.BODY_COM_ABOVE_HIP, C.MASS_WHEEL, C.MASS_LEG,
                                  BODY_MASS_SIDE, WHEEL_SPIN_INERTIA, BODY_PITCH_INERTIA_SIDE, C.GRAVITY)
    R, l, mw, mp, M, Iw, IM, g = (sp.Float(v, 17) for v in (R, l, mw, mp, M, Iw, IM, g))
    # forces: leg on body (Nm, Pm), wheel on leg (N, P); seed (1.4), (1.5), (1.7), (1.8)
    Nm = M * (ddx + (L + LM) * (ddth * sp.cos(th) - dth**2 * sp.sin(th))
              - l * (ddph * sp.cos(ph) - dph**2 * sp.sin(ph)))
    Pm = M * g + M * ((L + LM) * (-dth**2 * sp.cos(th) - ddth * sp.sin(th))
                      - l * (dph**2 * sp.cos(ph) + ddph * sp.sin(ph)))
    N = Nm + mp * (ddx + L * (ddth * sp.cos(th) - dth**2 * sp.sin(th)))
    Pf = Pm + mp * g + mp * L * (-dth**2 * sp.cos(th) - ddth * sp.sin(th))
    equations = [
        ddx - (T - N * R) / (Iw / R + mw * R),  # (1.3)
        Ip * ddth - ((Pf * L + Pm * LM) * sp.sin(th) - (N * L + Nm * LM) * sp.cos(th) - T + Tp),  # (1.6)
        IM * ddph - (Tp + Nm * l * sp.cos(ph) + Pm * l * sp.sin(ph)),  # (1.9)
    ]
    mass, rhs = sp.linear_eq_to_matrix(equations, [ddth, ddx, ddph])
    state, inputs = [th, dth, x, dx, ph, dph], [T, Tp]
    upright = {s: 0 for s in state + inputs}
    args = (L, LM, Ip)
    return (sp.lambdify(args, mass.subs(upright), "numpy"),
            sp.lambdify(args, rhs.jacobian(state).subs(upright), "numpy"),
            sp.lambdify(args, rhs.jacobian(inputs).subs(upright), "numpy"))


def continuous_model(L0: float) -> tuple[np.ndarray, np.ndarray]:
    """(A (6, 6), B (6, 2)) of the pendulum linearised upright at leg length L0 (m)."""
    mass_fn, dbdx_fn, dbdu_fn = _linearised_model()
    leg = leg_mass_properties(L0)
    args = (leg.L, leg.LM, leg.Ip)
    mass = np.asarray(mass_fn(*args), dtype=float)
    acc_x = np.linalg.solve(mass, np.asarray(dbdx_fn(*args), dtype=float))  # rows ddtheta, ddx, ddphi
    acc_u = np.linalg.solve(mass, np.asarray(dbdu_fn(*args), dtype=float))
    a = np.zeros((6, 6))
    b = np.zeros((6, 2))
    for row, pos in enumerate((0, 2, 4)):
        a[pos, pos + 1] = 1.0
        a[pos + 1] = acc_x[row]
        b[pos + 1] = acc_u[row]
    return a, b


def acceleration_equilibrium(L0: float) -> np.ndarray:
    """(theta rad, T N m, Tp N m) per m/s^2 of steady acceleration at leg length L0 (m), shape (3,).

    Accelerating steadily at a with the body level (phi = 0, all rates constant), the
    model's theta, x and phi rows of A s + B u read (0, a, 0); neither x nor its speed
    enters them, so theta, T and Tp follow from one 3x3 solve, each linear in a. The
    legs lean into the acceleration (theta > 0 speeding up: the wheel behind the hip);
    controller/params.py LEAN_PER_ACCEL is theta here at the nominal leg length.
    """
    a, b = continuous_model(L0)
    rows = [2 * i + 1 for i in range(3)]  # ddtheta, ddx, ddphi
    unknowns = np.column_stack([a[rows, STATE_NAMES.index("theta")], b[rows]])
    return np.linalg.solve(unknowns, np.array([0.0, 1.0, 0.0]))


def discretise(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order hold: (Ad (n, n), Bd (n, m)) from expm([[A, B], [0, 0]] dt)."""
    n, m = b.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = a, b
    phi = scipy.linalg.expm(block * dt)
    return phi[:n, :n], phi[:n, n:]


def dlqr(ad: np.ndarray, bd: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Discrete LQR gain K (m, n) for u = -K x: K = (R + B'PB)^-1 B'PA."""
    p = scipy.linalg.solve_discrete_are(ad, bd, q, r)
    return np.linalg.solve(r + bd.T @ p @ bd, bd.T @ p @ ad)


def augmented_model(ad: np.ndarray, bd: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(Aa (9, 9), Ba (9, 2)) of the discrete plant (Ad (6, 6), Bd (6, 2)) with the
    position integral and one period of input delay (module docstring):

      x[k+1] = Ad x[k] + Bd u[k-1],  ix[k+1] = ix[k] + dt x_pos[k],  u_prev[k+1] = u[k]
    """
    n, m = bd.shape
    aa, ba = np.zeros((n + 1 + m, n + 1 + m)), np.zeros((n + 1 + m, m))
    aa[:n, :n], aa[:n, n + 1:] = ad, bd
    aa[n, n] = 1.0
    aa[n, STATE_NAMES.index("x")] = dt
    ba[n + 1:] = np.eye(m)
    return aa, ba


def weights() -> tuple[np.ndarray, np.ndarray]:
    """(Q (9, 9), R (2, 2)) of the augmented design: the delayed commands are not weighted."""
    q = np.diag(tuple(P.LQR_Q) + (P.LQR_Q_INTEGRAL,) + (0.0,) * len(INPUT_NAMES))
    return q, np.diag(P.LQR_R)


def gains(L0: float, dt: float = P.CONTROL_PERIOD) -> np.ndarray:
    """Exact discrete LQR gain K (2, 9) of the augmented model at leg length L0 (m), period dt (s)."""
    ad, bd = discretise(*continuous_model(L0), dt)
    return dlqr(*augmented_model(ad, bd, dt), *weights())


def evaluate_fit(coeffs: np.ndarray, L0) -> np.ndarray:
    """K from fitted coefficients (2, 9, 4), highest power first, at L0 (m): (..., 2, 9)."""
    L0 = np.asarray(L0, dtype=float)[..., None, None]
    out = np.zeros(L0.shape[:-2] + coeffs.shape[:2])
    for power in range(coeffs.shape[2]):
        out = out * L0 + coeffs[:, :, power]
    return out


@dataclass(frozen=True)
class Design:
    """A gain table: the exact K at the grid and its cubic fit."""

    dt: float  # s
    grid: np.ndarray  # (n,) m
    K: np.ndarray  # (n, 2, 9) exact gains at the grid
    coeffs: np.ndarray  # (2, 9, 4) cubic in L0, highest power first
    fit_error: float  # max|K_fit - K| / max|K| over FIT_SAMPLES leg lengths
    arm_coeffs: np.ndarray  # (4,) ``static_arm`` as a cubic in L0, highest power first


def design(dt: float = P.CONTROL_PERIOD, points: int = P.LQR_GRID_POINTS,
           l0_min: float = P.LEG_LENGTH_MIN, l0_max: float = P.LEG_LENGTH_MAX) -> Design:
    """K at ``points`` leg lengths over [l0_min, l0_max] (m) and its cubic fit."""
    if not dt > 0:
        raise ValueError(f"dt must be positive, got {dt}")
    grid = np.linspace(l0_min, l0_max, points)
    k = np.array([gains(L0, dt) for L0 in grid])
    flat = k.reshape(points, -1)
    coeffs = np.polyfit(grid, flat, FIT_ORDER).T.reshape(len(INPUT_NAMES), len(GAIN_NAMES), FIT_ORDER + 1)
    samples = np.linspace(l0_min, l0_max, FIT_SAMPLES)
    exact = np.array([gains(L0, dt) for L0 in samples])
    err = float(np.max(np.abs(evaluate_fit(coeffs, samples) - exact)) / np.max(np.abs(exact)))
    arm = np.polyfit(grid, [static_arm(L0) for L0 in grid], FIT_ORDER)
    return Design(dt, grid, k, coeffs, err, arm)


# --- the generated module -----------------------------------------------------------
def render(d: Design) -> str:
    """Source of controller/lqr_gains.py for design ``d`` (no timestamps: reproducible)."""
    leg_lo, leg_hi = leg_mass_properties(d.grid[0]), leg_mass_properties(d.grid[-1])
    lines = [
        '"""LQR gains K(L0), each a cubic in the leg length L0.',
        "",
        "generated by python -m wheelleg.controller.design.lqr; do not edit.",
        "",
        f"dt = {d.dt!r} s (exact zero-order hold), discrete LQR",
        f"Q = diag{tuple(P.LQR_Q)!r}  (theta, dtheta, x, dx, phi, dphi)",
        f"Q_integral = {P.LQR_Q_INTEGRAL!r}  (ix); delayed commands T_prev, Tp_prev unweighted",
        f"R = diag{tuple(P.LQR_R)!r}  (T, Tp)",
        f"L0 over [{float(d.grid[0])!r}, {float(d.grid[-1])!r}] m, {len(d.grid)} grid points",
        f"fit error max|K_fit - K| / max|K| = {d.fit_error:.2e} over {FIT_SAMPLES} samples",
        f"per-side model: M = {BODY_MASS_SIDE:.4f} kg, I_M = {BODY_PITCH_INERTIA_SIDE:.5f} kg m^2,",
        f"m_p = {C.MASS_LEG} kg, m_w = {C.MASS_WHEEL} kg, l = {C.BODY_COM_ABOVE_HIP} m;",
        f"leg L/LM/Ip = {leg_lo.L:.4f}/{leg_lo.LM:.4f}/{leg_lo.Ip:.5f} at L0 min, "
        f"{leg_hi.L:.4f}/{leg_hi.LM:.4f}/{leg_hi.Ip:.5f} at max",
        "",
        "u = -K (s - s_ref), s = [theta, dtheta, x, dx, phi, dphi, ix, T_prev, Tp_prev],",
        "u = [T, Tp]: T wheel torque per wheel (forward rolling positive), Tp virtual",
        "hip torque per leg (drives theta positive); ix the position error's integral",
        "(m s), T_prev/Tp_prev last period's command (N m). See controller/design/lqr.py.",
        "COEFFS[i][j] = (c3, c2, c1, c0): K[i][j] = ((c3 L0 + c2) L0 + c1) L0 + c0.",
        "ARM = (c3, c2, c1, c0): g (M L0 + m_p L) in N m, the static moment arm of the",
        "balance point (design.static_arm): sin(theta) = -Tp / ARM(L0) standing still.",
        '"""',
        "",
        f"DT = {d.dt!r}",
        f"L0_MIN = {float(d.grid[0])!r}",
        f"L0_MAX = {float(d.grid[-1])!r}",
        f"GRID_POINTS = {len(d.grid)}",
        f"Q = {tuple(float(v) for v in P.LQR_Q)!r}",
        f"Q_INTEGRAL = {float(P.LQR_Q_INTEGRAL)!r}",
        f"R = {tuple(float(v) for v in P.LQR_R)!r}",
        "",
        "COEFFS = (",
    ]
    for i, name in enumerate(INPUT_NAMES):
        lines.append(f"    (  # {name}")
        for j, state in enumerate(GAIN_NAMES):
            c = ", ".join(repr(float(v)) for v in d.coeffs[i, j])
            lines.append(f"        ({c}),  # {state}")
        lines.append("    ),")
    lines.append(")")
    lines.append("")
    lines.append(f"ARM = ({', '.join(repr(float(v)) for v in d.arm_coeffs)})")
    return "\n".join(lines) + "\n"


def render_c(table) -> str:
    """Source of firmware/app/lqr_gains.c for a loaded gain ``table`` (``load_table``): the same
    numbers as float32 literals, in the same layout (rows T, Tp; GAIN_NAMES; c3..c0)."""
    def f(v: float) -> str:
        return f"{float(v)!r}f"
    lines = [
        "/* LQR gains K(L0), each a cubic in the leg length L0: the firmware's copy of",
        " * controller/lqr_gains.py, generated by python -m wheelleg.controller.design.lqr; do not edit.",
        f" * dt = {table.DT!r} s, L0 over [{table.L0_MIN!r}, {table.L0_MAX!r}] m.",
        " * WL_LQR_COEFFS[i][j] = {c3, c2, c1, c0}: K[i][j] = ((c3 L0 + c2) L0 + c1) L0 + c0,",
        f" * rows {', '.join(INPUT_NAMES)}; states {', '.join(GAIN_NAMES)}.",
        " * WL_LQR_ARM = {c3, c2, c1, c0}: the balance point's static moment arm (N m). */",
        '#include "lqr.h"',
        "",
        f"const float WL_LQR_DT = {f(table.DT)};",
        f"const float WL_LQR_L0_MIN = {f(table.L0_MIN)};",
        f"const float WL_LQR_L0_MAX = {f(table.L0_MAX)};",
        "const float WL_LQR_COEFFS[WL_LQR_INPUTS][WL_LQR_STATES][4] = {",
    ]
    for i, name in enumerate(INPUT_NAMES):
        lines.append(f"    {{  /* {name} */")
        for j, state in enumerate(GAIN_NAMES):
            lines.append(f"        {{{', '.join(f(v) for v in table.COEFFS[i][j])}}},  /* {state} */")
        lines.append("    },")
    lines.append("};")
    lines.append(f"const float WL_LQR_ARM[4] = {{{', '.join(f(v) for v in table.ARM)}}};")
    return "\n".join(lines) + "\n"


def load_table(path: Path | None = None):
    """The gain module at ``path`` (default GAINS_PATH), loaded fresh from the file.

    Compiled from the text, not imported: an import may take a cached ``__pycache__``
    copy, stale when the file was rewritten within the same second at the same size.
    """
    path = Path(path or GAINS_PATH)
    module = types.ModuleType("_lqr_gains_on_disk")
    module.__file__ = str(path)
    exec(compile(path.read_text(), str(path), "exec"), module.__dict__)
    return module


# Relative agreement asked of a regenerated table. The Riccati solve and the fits
# differ by ~1e-9 between scipy/LAPACK builds (1.3e-9 seen with scipy 1.17 against the
# committed table); any change to the robot, Q, R or the period moves them by >1e-4.
TABLE_RTOL = 1e-7


def table_matches(d: Design, table, rtol: float = TABLE_RTOL) -> list[str]:
    """Differences between design ``d`` and a loaded gain table; [] when they agree."""
    problems = []
    for name, want in (("DT", d.dt), ("L0_MIN", float(d.grid[0])), ("L0_MAX", float(d.grid[-1])),
                       ("GRID_POINTS", len(d.grid)), ("Q", tuple(map(float, P.LQR_Q))),
                       ("Q_INTEGRAL", float(P.LQR_Q_INTEGRAL)),
                       ("R", tuple(map(float, P.LQR_R)))):
        if getattr(table, name, None) != want:
            problems.append(f"{name}: table {getattr(table, name, None)!r}, design {want!r}")
    coeffs = np.array(getattr(table, "COEFFS", ()), dtype=float)
    if coeffs.shape != d.coeffs.shape:
        return problems + [f"COEFFS shape {coeffs.shape}, expected {d.coeffs.shape}"]
    # compare per gain, relative to that gain's largest coefficient
    scale = np.max(np.abs(d.coeffs), axis=2, keepdims=True)
    worst = float(np.max(np.abs(coeffs - d.coeffs) / scale))
    if worst > rtol:
        problems.append(f"COEFFS differ by {worst:.3e} (relative), more than {rtol:g}")
    arm = np.array(getattr(table, "ARM", ()), dtype=float)
    if arm.shape != d.arm_coeffs.shape or np.max(np.abs(arm - d.arm_coeffs)) > rtol * np.max(np.abs(d.arm_coeffs)):
        problems.append(f"ARM {tuple(arm)} differs from the design's {tuple(d.arm_coeffs)}")
    return problems


def c_table_current(table, rtol: float = TABLE_RTOL) -> list[str]:
    """[] when firmware/app/lqr_gains.c holds ``table``'s numbers (to ``rtol`` of each gain's
    largest coefficient, as ``table_matches``: a regenerated table may differ by ~1e-9 between
    LAPACK builds); else what is wrong with it."""
    try:
        text = C_GAINS_PATH.read_text()
    except OSError as exc:
        return [f"cannot read {C_GAINS_PATH}: {exc}"]
    want = [*(float(v) for row in table.COEFFS for gain in row for v in gain), *(float(v) for v in table.ARM)]
    definition = text.split("const float WL_LQR_COEFFS", 1)[-1]  # the numbers after the header
    got = [float(v) for v in re.findall(r"(-?[0-9][0-9.]*(?:e[-+]?[0-9]+)?)f\b", definition)]
    if len(got) != len(want):
        return [f"{C_GAINS_PATH.name} holds {len(got)} coefficients, the table {len(want)}: regenerate it"]
    scale = np.repeat(np.max(np.abs(np.reshape(want, (-1, FIT_ORDER + 1))), axis=1), FIT_ORDER + 1)
    worst = float(np.max(np.abs(np.subtract(got, want)) / scale))
    if worst > rtol:
        return [f"{C_GAINS_PATH.name} differs from the Python table by {worst:.3e} (relative)"]
    return []


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wheelleg.controller.design.lqr", description=__doc__.split("\n")[0])
    parser.add_argument("--dt", type=float, default=P.CONTROL_PERIOD, help="control period in s")
    parser.add_argument("--check", action="store_true",
                        help="do not write; exit 1 if the committed table differs from a fresh design")
    args = parser.parse_args(argv)
    d = design(args.dt)
    k_nom = gains(P.LEG_LENGTH_NOMINAL, args.dt)
    print(f"dt {d.dt} s, {len(d.grid)} points over [{float(d.grid[0])}, {float(d.grid[-1])}] m, fit error {d.fit_error:.2e}")
    print(f"K at L0 = {P.LEG_LENGTH_NOMINAL} m:\n{np.array2string(k_nom, precision=4, suppress_small=True)}")
    if args.check:
        try:
            table = load_table()
            problems = table_matches(d, table) + c_table_current(table)
        except (OSError, SyntaxError) as exc:
            problems = [f"cannot load {GAINS_PATH}: {exc}"]
        for p in problems:
            print(f"stale table: {p}", file=sys.stderr)
        if problems:
            print("run: python -m wheelleg.controller.design.lqr", file=sys.stderr)
            return 1
        print(f"{GAINS_PATH.name} is up to date")
        return 0
    GAINS_PATH.write_text(render(d))
    print(f"wrote {GAINS_PATH}")
    C_GAINS_PATH.write_text(render_c(load_table()))
    print(f"wrote {C_GAINS_PATH}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
