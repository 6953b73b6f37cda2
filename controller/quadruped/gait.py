"""The trot: diagonal pairs, a phase clock, swing curves and Raibert's foot placement.

Frames: everything is planned in the level frame (sensed.py: the body's centre,
z up, x along the heading), which moves with the body. A stance foot is fixed
on the ground, so in this frame it moves by -(v + w x p) dt each period: that
motion, followed by the joint PD, is what carries the body at the set velocity
v (m/s, (2,)) and yaw rate w (rad/s). A swing foot leaves where its stance
ended and lands at Raibert's point

    p_td = p_hip + v T_stance / 2 + k (v - v_cmd)

(p_hip under the hip, v the measured velocity from leg odometry, v_cmd the set
point): the feet land ahead by half a stance's travel, plus more when the
body runs faster than asked, which brakes it. The stance feet are posed for a
level body turned by ``attitude_trim``, the integral of the measured roll and
pitch (as the balance stand's trims): a heavier rear, a CoM off its centre or
stiff joints no longer leave the trotting body pitched. Arrays: feet (4, 3) m; pairs
``constants.PAIRS`` (FR+RL, FL+RR).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wheelleg.controller.bounds import within
from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped import legs, stance
from wheelleg.controller.quadruped.balance import slew, slew_scalar
from wheelleg.controller.quadruped.getup import min_jerk
from wheelleg.controller.quadruped.legs import JointCommands
from wheelleg.controller.quadruped.rotations import rot_z, rpy_matrix, wrap
from wheelleg.controller.quadruped.sensed import Sensed, height_over_feet

PHASE_OFFSET = np.array([0.0, 0.5, 0.5, 0.0])  # FR, FL, RR, RL: the two diagonal pairs half a cycle apart


@dataclass(frozen=True)
class Velocity:
    """What the remote asks of the trot: forward and lateral speed (m/s), yaw rate (rad/s)."""

    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0

    def limited(self) -> "Velocity":
        (vx_max, vy_max), w_max = P.VELOCITY_LIMIT, P.YAW_RATE_LIMIT
        # bounds.within makes np.clip's comparisons on one float (NaN stays NaN), without numpy's per-call cost
        return Velocity(within(self.vx, -vx_max, vx_max), within(self.vy, -vy_max, vy_max),
                        within(self.yaw_rate, -w_max, w_max))


def leg_phases(clock: float) -> np.ndarray:
    """Each leg's phase in [0, 1) at the gait ``clock`` (cycles, [0, 1)): stance first, then swing."""
    return (clock + PHASE_OFFSET) % 1.0


def in_stance(phases: np.ndarray, duty: float = P.DUTY) -> np.ndarray:
    """Bool (4,): the legs whose phase is in the stance part of the cycle."""
    return phases < duty


def swing_point(start: np.ndarray, end: np.ndarray, progress: float, height_m: float,
                duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Position (m, (3,)) and velocity (m/s, (3,)) of a swing foot at ``progress`` in [0, 1].

    Minimum-jerk from ``start`` to ``end`` with a lift of 16 s^2 (1 - s)^2 times
    ``height_m`` (peak at mid-swing, flat at lift-off and touchdown).
    """
    s = min(max(progress, 0.0), 1.0)
    position, rate = min_jerk(s)
    lift = 16.0 * s * s * (1.0 - s) ** 2
    lift_rate = 32.0 * s * (1.0 - s) * (1.0 - 2.0 * s)
    point = start + position * (end - start)
    point[2] += height_m * lift
    velocity = (rate * (end - start) + np.array([0.0, 0.0, height_m * lift_rate])) / duration_s
    return point, velocity


def raibert_touchdown(under_hip: np.ndarray, velocity: np.ndarray, velocity_set: np.ndarray, yaw_rate: float,
                      stance_s: float, gain_s: float, reach_m: float) -> np.ndarray:
    """Touchdown point (m, (3,), level frame) of a foot whose neutral point is ``under_hip`` (m, (3,)).

    ``velocity`` measured and ``velocity_set`` asked (m/s, (2,)); the yaw rate
    (rad/s) moves the neutral point along its circle as the velocity does;
    the shift is capped at ``reach_m``.
    """
    turning = yaw_rate * np.array([-under_hip[1], under_hip[0]])
    shift = (velocity + turning) * stance_s / 2.0 + gain_s * (velocity - velocity_set)
    norm = float(np.hypot(*shift))
    if norm > reach_m:
        shift *= reach_m / norm
    return under_hip + np.array([shift[0], shift[1], 0.0])


def odometry_velocity(sensed: Sensed, stance_mask: np.ndarray) -> np.ndarray | None:
    """The body's velocity (m/s, (2,), level frame) from the stance feet, or None without one.

    A stance foot is still on the ground, so the body moves at -(foot's velocity
    relative to the body + w x foot): the mean over the stance feet.
    """
    if not np.any(stance_mask):
        return None
    relative = legs.foot_velocities(sensed.q, sensed.qd) + cross_rows(sensed.gyro, sensed.feet_body)
    body = -relative[stance_mask].mean(axis=0)
    return (sensed.level_rotation @ body)[:2]


def cross_rows(w: np.ndarray, points: np.ndarray) -> np.ndarray:
    """w x p (shape (n, 3)) of one vector ``w`` (3,) and each row p of ``points`` (n, 3).

    np.cross's own products and differences (a1 b2 - a2 b1, ...: each an IEEE
    multiply, then a subtract), without its general-shape handling.
    """
    w0, w1, w2 = w.tolist()
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    return np.stack((w1 * z - w2 * y, w2 * x - w0 * z, w0 * y - w1 * x), axis=1)


class Trot:
    """``start`` from a stand, then ``step`` every period with the remote's velocity and height."""

    def __init__(self, period_s: float = P.CONTROL_PERIOD):
        self.period_s = period_s
        self.clock = 0.0
        self.feet = stance.footprint()  # m, (4, 3) level frame: this period's foot set points
        self.lift_off = self.feet.copy()  # where each swing began
        self.was_stance = np.ones(4, dtype=bool)
        self.parked = np.zeros(4, dtype=bool)  # feet kept down while stopping
        self.velocity_set = np.zeros(3)  # vx, vy (m/s), yaw rate (rad/s) after the slew
        self.velocity = np.zeros(2)  # m/s, the filtered leg-odometry estimate
        self.heading_ref = 0.0
        self.feet_yaw_rate = 0.0  # rad/s, the yaw rate the stance feet carried in the last period
        self.height = P.HEIGHT_NOMINAL
        self.attitude_trim = np.zeros(2)  # rad, roll and pitch the stance feet pose the body by

    def start(self, sensed: Sensed) -> None:
        """Begin from the feet where they are (all down), at rest, holding the heading."""
        self.clock = 0.0
        self.feet = sensed.feet_level()
        self.lift_off = self.feet.copy()
        self.was_stance = np.ones(4, dtype=bool)
        self.parked = np.zeros(4, dtype=bool)
        self.velocity_set = np.zeros(3)
        self.velocity = np.zeros(2)
        self.heading_ref = float(sensed.rpy[2])
        self.feet_yaw_rate = 0.0
        self.height = height_over_feet(self.feet, np.ones(4, dtype=bool))
        self.attitude_trim = np.zeros(2)

    @property
    def stance_s(self) -> float:
        return P.DUTY * P.GAIT_PERIOD

    @property
    def settled(self) -> bool:
        """Stopping has put every foot down: a stand can take the feet where they are."""
        return bool(np.all(self.parked))

    def step(self, sensed: Sensed, asked: Velocity, height_m: float, stopping: bool = False) -> JointCommands:
        """This period's joint commands. ``stopping``: slow to rest, and let each foot that is
        down (or lands) stay down, so that after at most one swing all four are (``settled``)."""
        dt = self.period_s
        self._estimate(sensed)
        target = Velocity() if stopping else asked.limited()
        limits = np.array([P.ACCELERATION, P.ACCELERATION, P.YAW_ACCELERATION]) * dt
        self.velocity_set = slew(self.velocity_set, np.array([target.vx, target.vy, target.yaw_rate]), limits)
        self.height = slew_scalar(self.height, height_m, P.HEIGHT_RATE * dt)
        yaw_rate = self.feet_yaw_rate = self._yaw_rate(float(sensed.rpy[2]))
        self.clock = (self.clock + dt / P.GAIT_PERIOD) % 1.0
        phases = leg_phases(self.clock)
        stance_mask = in_stance(phases) | self.parked
        if stopping:
            self.parked = self.parked | stance_mask
        velocities = np.zeros((4, 3))
        for leg in range(4):
            if stance_mask[leg]:
                velocities[leg] = self._stance_foot(leg, yaw_rate)
            else:
                velocities[leg] = self._swing_foot(leg, phases[leg], yaw_rate)
        self.was_stance = stance_mask
        return self._commands(sensed, stance_mask, velocities)

    def _estimate(self, sensed: Sensed) -> None:
        measured = odometry_velocity(sensed, self.was_stance)
        if measured is not None:
            alpha = self.period_s / (P.VELOCITY_FILTER_S + self.period_s)
            self.velocity += alpha * (measured - self.velocity)

    def _yaw_rate(self, yaw: float) -> float:
        """The set yaw rate plus the heading correction (the reference integrates the set rate)."""
        self.heading_ref += self.velocity_set[2] * self.period_s
        error = wrap(self.heading_ref - yaw)
        if abs(error) > P.HEADING_ERROR_LIMIT:  # held back (a push, a slip): carry only the limit
            error = float(np.sign(error)) * P.HEADING_ERROR_LIMIT
            self.heading_ref = yaw + error
        return float(self.velocity_set[2] + P.HEADING_KP * error)

    def _stance_foot(self, leg: int, yaw_rate: float) -> np.ndarray:
        """Move a stance foot by the body's motion; its velocity (m/s, (3,)) in the level frame."""
        dt = self.period_s
        foot = self.feet[leg]
        velocity = -np.array([self.velocity_set[0] - yaw_rate * foot[1], self.velocity_set[1] + yaw_rate * foot[0],
                              0.0])
        moved = rot_z(-yaw_rate * dt) @ foot - np.array([self.velocity_set[0], self.velocity_set[1], 0.0]) * dt
        ground = -(self.height - C.FOOT_RADIUS)
        moved[2] = slew_scalar(float(foot[2]), ground, P.HEIGHT_RATE * dt)
        self.feet[leg] = moved
        return velocity

    def _swing_foot(self, leg: int, phase: float, yaw_rate: float) -> np.ndarray:
        """Move a swing foot along its curve toward Raibert's point; its velocity (m/s, (3,))."""
        if self.was_stance[leg]:
            self.lift_off[leg] = self.feet[leg].copy()
        swing_s = (1.0 - P.DUTY) * P.GAIT_PERIOD
        under_hip = stance.footprint()[leg]
        under_hip[2] = -(self.height - C.FOOT_RADIUS)
        land = raibert_touchdown(under_hip, self.velocity, self.velocity_set[:2], yaw_rate, self.stance_s,
                                 P.RAIBERT_GAIN, P.TOUCHDOWN_REACH)
        progress = (phase - P.DUTY) / (1.0 - P.DUTY)
        self.feet[leg], velocity = swing_point(self.lift_off[leg], land, progress, P.SWING_HEIGHT, swing_s)
        return velocity

    def _commands(self, sensed: Sensed, stance_mask: np.ndarray, velocities: np.ndarray) -> JointCommands:
        """IK of the foot set points, joint rates by J^-1, stance feed-forward.

        Stance feet are set as if the body were level: their PD pulls a tilted
        body back. Swing feet are set through the measured tilt, so that they
        land where planned on the ground whatever the body's roll and pitch.
        """
        tilt = sensed.level_rotation
        self.attitude_trim = np.clip(self.attitude_trim - P.ATTITUDE_KI * sensed.rpy[:2] * self.period_s,
                                     -P.ATTITUDE_TRIM_LIMIT, P.ATTITUDE_TRIM_LIMIT)
        posed = self.feet @ rpy_matrix(self.attitude_trim[0], self.attitude_trim[1])
        feet_body = np.where(stance_mask[:, None], posed, self.feet @ tilt)
        body_velocities = np.where(stance_mask[:, None], velocities, velocities @ tilt)
        q = legs.joints_for_feet(feet_body)
        qd = np.array([np.linalg.lstsq(J, v, rcond=None)[0] for J, v in zip(legs.jacobians(q), body_velocities)])
        kp = np.where(stance_mask[:, None], P.STANCE_KP, P.SWING_KP) * np.ones((4, 3))
        kd = np.where(stance_mask[:, None], P.STANCE_KD, P.SWING_KD) * np.ones((4, 3))
        error = np.array([-sensed.rpy[0], -sensed.rpy[1], 0.0])
        wrench = stance.attitude_wrench(C.MASS, error, sensed.gyro, np.array(P.ATTITUDE_KP), np.array(P.ATTITUDE_KD))
        tau = stance.stance_torques(sensed.q, sensed.feet_level(), sensed.level_rotation, wrench, stance_mask,
                                    P.DISTRIBUTION_REGULARISATION, P.FRICTION)
        return JointCommands(q, np.clip(qd, -C.VELOCITY_LIMIT, C.VELOCITY_LIMIT), kp, kd, tau)
