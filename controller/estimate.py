"""Estimators that keep the controller's picture right when the sensors are not.

``GyroBiasObserver``: a gyro's bias (power-on residue, temperature drift) goes
straight into the wheel-speed estimate (the wheel's encoder reads it against
the leg, so the body rate is added back) and into the LQR's body rate. The
IMU's own orientation is not biased, so the observer propagates an orientation
with the bias-corrected rates and trims the bias by how far that drifts from
the measured one (a complementary filter with bias, as in Mahony's: an
integral on the attitude error, body frame).

``BalancePointObserver``: a body whose CoM sits off the hip (the build, a battery
moved, a payload) or an IMU mounted tilted makes the robot balance with the legs
leaning, not upright. Standing still, the legs' lean says how far (the whole CoM is
over the axle, whatever the hips' dry friction holds); the hold torque of that lean
(controller/lqr.py ``lean_hold_torque``) is learnt, and the LQR balances about the lean
it implies (``balance_lean``) instead of dragging the wheels away from it until the
position integral has caught up.

Quaternions are (w, x, y, z) tuples, body to world; rates rad/s, body frame.
"""
from __future__ import annotations

import math

from wheelleg.controller.bounds import clamp


def quat_mul(a: tuple, b: tuple) -> tuple:
    """Hamilton product a b of two (w, x, y, z) quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def quat_conj(q: tuple) -> tuple:
    return (q[0], -q[1], -q[2], -q[3])


def rotation_vector(q: tuple) -> tuple:
    """Rotation vector (rad, (3,)) of unit quaternion ``q``, the short way round."""
    w, x, y, z = q if q[0] >= 0.0 else tuple(-v for v in q)
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return (2.0 * x, 2.0 * y, 2.0 * z)
    angle = 2.0 * math.atan2(s, w)
    return (angle * x / s, angle * y / s, angle * z / s)


def quat_exp(r: tuple) -> tuple:
    """Unit quaternion of the rotation vector ``r`` (rad, (3,))."""
    rx, ry, rz = r
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if angle < 1e-12:
        return (1.0, 0.5 * r[0], 0.5 * r[1], 0.5 * r[2])
    s = math.sin(0.5 * angle) / angle
    return (math.cos(0.5 * angle), r[0] * s, r[1] * s, r[2] * s)


class GyroBiasObserver:
    """Gyro bias (rad/s, (3,) body frame) from the rates against the IMU's own orientation.

    With natural frequency ``omega_n`` (rad/s) and damping 1 the attitude error
    closes through kp = 2 omega_n and the bias through ki = omega_n^2: a
    constant bias is found within ~5 / omega_n s; the orientation's noise
    reaches the bias only through that slow loop. ``limit`` (rad/s) bounds the
    estimate (a gyro beyond it is broken, not biased).
    """

    def __init__(self, dt_s: float, omega_n: float, limit: float):
        self.dt_s, self.limit = dt_s, limit
        self.kp, self.ki = 2.0 * omega_n, omega_n * omega_n
        self.bias = (0.0, 0.0, 0.0)
        self._quat: tuple | None = None  # the propagated orientation

    def update(self, quat: tuple, gyro: tuple) -> tuple:
        """One period: measured orientation and rates in, the bias estimate out."""
        if self._quat is None:
            self._quat = quat
            return self.bias
        # per axis, written out (every tick: no generators), each in the same order of operations
        ex, ey, ez = rotation_vector(quat_mul(quat_conj(self._quat), quat))  # measured relative to propagated
        (bx, by, bz), (gx, gy, gz) = self.bias, gyro
        ki, kp, dt, limit = self.ki, self.kp, self.dt_s, self.limit
        bx = clamp(bx - ki * ex * dt, limit)
        by = clamp(by - ki * ey * dt, limit)
        bz = clamp(bz - ki * ez * dt, limit)
        self.bias = (bx, by, bz)
        rate_dt = ((gx - bx + kp * ex) * dt, (gy - by + kp * ey) * dt, (gz - bz + kp * ez) * dt)
        w, x, y, z = quat_mul(self._quat, quat_exp(rate_dt))
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        self._quat = (w / norm, x / norm, y / norm, z / norm)
        return self.bias


def forward_accel(quat: tuple, specific_force: tuple) -> float:
    """World-horizontal acceleration (m/s^2) along the body's heading, gravity removed.

    quat (w, x, y, z) body->world, specific_force (3,) body frame (+g on z at rest):
    a_world = R f - g z, projected on (cos yaw, sin yaw, 0).
    """
    w, x, y, z = quat
    fx, fy, fz = specific_force
    ax = (1 - 2 * (y * y + z * z)) * fx + 2 * (x * y - w * z) * fy + 2 * (x * z + w * y) * fz
    ay = 2 * (x * y + w * z) * fx + (1 - 2 * (x * x + z * z)) * fy + 2 * (y * z - w * x) * fz
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return ax * math.cos(yaw) + ay * math.sin(yaw)


class SlipObserver:
    """Whether the wheels slip, and the body's ground speed (m/s) while they do.

    The body's forward speed ``speed_m_s`` follows the IMU's acceleration and is
    pulled towards the wheels' own figure (their speed less the legs' motion under
    the body) at ``gain`` (1/s) while they grip. Slipping is declared when the two
    part by more than ``on_m_s``; while slipping the pull stops, so a spinning or
    skidding wheel cannot drag the estimate along. Grip is back when the two agree
    within ``grip_m_s`` again, or when over a window of ``window_s`` the wheels'
    speed changed as the IMU's did (within ``grip_m_s``): the estimate then takes
    the wheels' figure, so an estimate that drifted while slipping (a bias, a
    landing's jolt) cannot hold the flag on.
    An accelerometer bias b leaves b / gain (m/s) between them while gripping:
    3 deg of mounting tilt (0.5 m/s^2) at gain 10 is 0.05 m/s, well below ``on_m_s``.
    """

    def __init__(self, dt_s: float, gain: float, on_m_s: float, window_s: float, grip_m_s: float):
        self.dt_s, self.gain, self.on_m_s = dt_s, gain, on_m_s
        self.window_s, self.grip_m_s = window_s, grip_m_s
        self.speed_m_s = 0.0
        self.slipping = False
        self._window = (0.0, 0.0, 0.0)  # (s elapsed, IMU speed change m/s, wheels' speed at its start m/s)

    def update(self, accel_m_s2: float, wheels_body_speed_m_s: float) -> bool:
        """One period: the forward acceleration (m/s^2) and the body speed the wheels
        report (m/s) in; whether they slip out."""
        self.speed_m_s += accel_m_s2 * self.dt_s
        if self.slipping:
            self._watch_grip(accel_m_s2, wheels_body_speed_m_s)
        elif abs(wheels_body_speed_m_s - self.speed_m_s) > self.on_m_s:
            self.slipping, self._window = True, (0.0, 0.0, wheels_body_speed_m_s)
        if not self.slipping:
            self.speed_m_s += self.gain * (wheels_body_speed_m_s - self.speed_m_s) * self.dt_s
        return self.slipping

    def _watch_grip(self, accel_m_s2: float, wheels_m_s: float) -> None:
        elapsed, imu_change, wheels_start = self._window
        elapsed, imu_change = elapsed + self.dt_s, imu_change + accel_m_s2 * self.dt_s
        if abs(wheels_m_s - self.speed_m_s) < self.grip_m_s:
            self.slipping = False
        elif elapsed < self.window_s:
            self._window = (elapsed, imu_change, wheels_start)
        elif abs((wheels_m_s - wheels_start) - imu_change) < self.grip_m_s:
            self.slipping, self.speed_m_s = False, wheels_m_s
        else:
            self._window = (0.0, 0.0, wheels_m_s)


class BalancePointObserver:
    """The hip torque (N m per leg) that holds the body at rest: the balance point.

    ``hold_torque`` follows the hold torque of the legs' lean (``update``, fed by the
    chassis with ``lqr.lean_hold_torque`` of the mean leg angle less the acceleration's
    lean) through a first-order lag: ``tau_learn_s`` for the first
    ``learn_s`` after it first stands (time, whether it stands on or not), so the robot
    finds its balance point before it has rolled far from where it was put down;
    ``tau_s`` afterwards, slow enough that a push's lean (a few hundred ms) barely moves
    it. Counted in standing time only, a robot pushed off its spot early (walking back,
    nothing is learnt) still had the fast lag seconds later, and a steady push then was
    learnt as the CoM's lean (docs/control.md, the balance point). It is kept across
    falls and re-enables: the CoM does not move when the robot falls. A push at body
    height leans the legs as a CoM offset does: nothing is learnt while the robot moves
    faster than ``still_m_s`` (m/s) nor for ``settle_s`` after, so a sudden push leaks
    in only the few ms before the robot picks up speed.
    """

    def __init__(self, dt_s: float, tau_learn_s: float, learn_s: float, tau_s: float,
                 still_m_s: float = math.inf, settle_s: float = 0.0):
        self.dt_s, self.tau_learn_s, self.learn_s, self.tau_s = dt_s, tau_learn_s, learn_s, tau_s
        self.still_m_s, self.settle_s = still_m_s, settle_s
        self._blocked_s = 0.0  # s left before learning again after the robot last moved fast
        self.hold_torque = 0.0  # N m per leg
        # the start-up window in ticks, counted from the first standing one: a whole count, so
        # the firmware's window ends on the same tick (a float sum of dt_s may not)
        self.learn_ticks = round(learn_s / dt_s)
        self.learnt_ticks = 0

    def update(self, lean_hold_torque_nm: float, speed_m_s: float, standing: bool) -> float:
        """One period: the hold torque the legs' lean implies (N m per leg), the ground speed
        (m/s) and whether the robot stands still and settled (its position integral runs)."""
        if abs(speed_m_s) > self.still_m_s:
            self._blocked_s = self.settle_s
        self._blocked_s = max(0.0, self._blocked_s - self.dt_s)
        tau = self.tau_learn_s if self.learnt_ticks < self.learn_ticks else self.tau_s
        if (standing or self.learnt_ticks > 0) and self.learnt_ticks < self.learn_ticks:  # runs on once begun
            self.learnt_ticks += 1
        if not standing or self._blocked_s > 0.0:
            return self.hold_torque
        self.hold_torque += (lean_hold_torque_nm - self.hold_torque) * min(1.0, self.dt_s / tau)
        return self.hold_torque
