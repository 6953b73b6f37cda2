"""The balance stand: four feet fixed on the ground, the body posed from the remote.

At ``start`` the feet's points on the ground are taken as they are (the ground
frame G of stance.py, centred under their centroid, x along the heading); a
foot caught in the air (a trot stopped mid-swing) is brought down to the
ground under where it is.
Each ``step`` slews the set points (roll, pitch, yaw relative to the start's
heading, height), adds the trims that integrate what the IMU and the legs
measure against them, poses the body by IK and carries its weight with the
force distribution's feed-forward. The IMU's roll and pitch are taken less the
mount's tilt, which the stand estimates (``mount_tilt``) while all four feet
are down: the slow part of the IMU's difference from the legs' attitude over
their plane (params.MOUNT_TILT_TAU says why).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wheelleg.controller.bounds import within
from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped import legs, stance
from wheelleg.controller.quadruped.legs import JointCommands
from wheelleg.controller.quadruped.rotations import rpy_matrix, wrap
from wheelleg.controller.quadruped.sensed import Sensed, height_over_feet, read_only

# constant arrays of the parameters, made once (read-only)
ATTITUDE_KP, ATTITUDE_KD = read_only(np.array(P.ATTITUDE_KP)), read_only(np.array(P.ATTITUDE_KD))
TRIM_GAINS = read_only(np.array([P.ATTITUDE_KI] * 3 + [P.HEIGHT_KI]))
TRIM_LIMITS = read_only(np.array([P.ATTITUDE_TRIM_LIMIT] * 3 + [P.HEIGHT_TRIM_LIMIT]))
_ORIGIN_XY = read_only(np.zeros(2))


@dataclass(frozen=True)
class Posture:
    """Body set points: roll, pitch, yaw (rad; yaw relative to the stand's start) and height (m)."""

    roll: float = 0.0
    pitch: float = 0.0
    yaw: float = 0.0
    height: float = P.HEIGHT_NOMINAL

    def as_array(self) -> np.ndarray:
        return np.array([self.roll, self.pitch, self.yaw, self.height])


def limited(posture: Posture) -> Posture:
    """``posture`` within the attitude limit and the height range."""
    a, (low, high) = P.ATTITUDE_LIMIT, P.HEIGHT_RANGE
    # bounds.within makes np.clip's comparisons on one float (NaN stays NaN), without numpy's per-call cost
    return Posture(within(posture.roll, -a, a), within(posture.pitch, -a, a), within(posture.yaw, -a, a),
                   within(posture.height, low, high))


def slew(current: np.ndarray, target: np.ndarray, max_step: np.ndarray) -> np.ndarray:
    """``current`` moved toward ``target`` by at most ``max_step`` (elementwise)."""
    return current + np.clip(target - current, -max_step, max_step)


def slew_scalar(current: float, target: float, max_step: float) -> float:
    """``slew`` of one float (the same operations, in Python floats)."""
    return current + within(target - current, -max_step, max_step)


class BalanceStand:
    """Holds the feet, poses the body: ``start`` once, then ``step`` every period."""

    def __init__(self, period_s: float = P.CONTROL_PERIOD):
        self.period_s = period_s
        self.feet_ground = stance.footprint()  # m, (4, 3): the feet's set points in G
        self.feet_goal = self.feet_ground.copy()  # m, (4, 3): the same on the ground
        self.down = np.ones(4, dtype=bool)  # the feet on the ground (carrying weight)
        self.body_xy = np.zeros(2)  # m, the body centre in G (slewed to the feet's centroid: 0)
        self.setpoint = Posture().as_array()  # roll, pitch, yaw, height being slewed
        self.trim = np.zeros(4)
        self.yaw0 = 0.0
        self.measured = self.setpoint.copy()  # roll, pitch, yaw, height as last measured
        self.mount_tilt = np.zeros(2)  # rad, roll and pitch of the IMU on the body, estimated (kept across stands)
        # the step's constant arrays, made once (read-only: every step reads them)
        self._rates = read_only(np.array([P.ATTITUDE_RATE] * 3 + [P.HEIGHT_RATE]) * period_s)
        self._xy_rates = read_only(np.full(2, P.HEIGHT_RATE * period_s))
        self._feet_rates = read_only(np.full((4, 3), P.FOOT_SETTLE_RATE * period_s))

    def start(self, sensed: Sensed) -> None:
        """Take the feet where they are and the body's posture as the first set point."""
        feet = sensed.feet_level()
        self.down = feet[:, 2] <= feet[:, 2].min() + 0.01  # the feet on the ground: on it exactly
        height = height_over_feet(feet, self.down)
        feet[:, 2] += height
        feet[self.down, 2] = C.FOOT_RADIUS
        centroid = feet[:, :2].mean(axis=0)
        feet[:, :2] -= centroid
        self.feet_ground = feet
        self.feet_goal = feet.copy()
        self.feet_goal[:, 2] = C.FOOT_RADIUS
        self.body_xy = -centroid
        self.yaw0 = float(sensed.rpy[2])
        self.trim = np.zeros(4)
        roll, pitch = self.body_attitude(sensed)
        self.setpoint = np.array([roll, pitch, 0.0, height])
        self.measured = self.setpoint.copy()

    def step(self, sensed: Sensed, target: Posture) -> JointCommands:
        dt = self.period_s
        self.setpoint = slew(self.setpoint, limited(target).as_array(), self._rates)
        self.body_xy = slew(self.body_xy, _ORIGIN_XY, self._xy_rates)
        self.feet_ground = slew(self.feet_ground, self.feet_goal, self._feet_rates)
        feet_level = sensed.feet_level()
        self.down = self.down | (np.abs(self.feet_ground[:, 2] - C.FOOT_RADIUS) < 1e-9)
        down = self.down
        if down.all():
            self._estimate_mount_tilt(sensed, dt)
        roll, pitch = self.body_attitude(sensed)
        self.measured = np.array([roll, pitch, wrap(sensed.rpy[2] - self.yaw0), height_over_feet(feet_level, down)])
        error = self.setpoint - self.measured
        self.trim = trimmed(self.trim, error, dt)
        pose = self.setpoint + self.trim
        body = np.array([self.body_xy[0], self.body_xy[1], pose[3]])
        q = legs.joints_for_feet(stance.feet_in_body_for_pose(self.feet_ground, body, rpy_matrix(*pose[:3])))
        wrench = stance.attitude_wrench(C.MASS, error[:3], sensed.gyro, ATTITUDE_KP, ATTITUDE_KD)
        tau = stance.stance_torques(sensed.q, feet_level, sensed.level_rotation, wrench, down,
                                    P.DISTRIBUTION_REGULARISATION, P.FRICTION)
        return JointCommands.hold(q, P.STANCE_KP, P.STANCE_KD, tau)

    def body_attitude(self, sensed: Sensed) -> tuple[float, float]:
        """The body's roll and pitch (rad): the IMU's less the estimated mount tilt."""
        return float(sensed.rpy[0] - self.mount_tilt[0]), float(sensed.rpy[1] - self.mount_tilt[1])

    def _estimate_mount_tilt(self, sensed: Sensed, dt: float) -> None:
        """Move the tilt estimate a step ``dt`` (s) toward the IMU's roll and pitch less the legs'."""
        legs_rp = stance.attitude_over_feet(sensed.feet_body)
        difference = np.array([sensed.rpy[0] - legs_rp[0], sensed.rpy[1] - legs_rp[1]])
        self.mount_tilt += dt / P.MOUNT_TILT_TAU * (difference - self.mount_tilt)
        np.clip(self.mount_tilt, -P.MOUNT_TILT_LIMIT, P.MOUNT_TILT_LIMIT, out=self.mount_tilt)


def trimmed(trim: np.ndarray, error: np.ndarray, dt: float) -> np.ndarray:
    """The posture trims (roll, pitch, yaw rad; height m) after integrating ``error`` for ``dt`` s."""
    return np.clip(trim + TRIM_GAINS * error * dt, -TRIM_LIMITS, TRIM_LIMITS)
