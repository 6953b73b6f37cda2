"""The quadruped controller in the tolerance box: the IMU mount tilt taken out of the stand, the trot's attitude trims."""
from __future__ import annotations

import math

import numpy as np
import pytest

from wheelleg.controller.quadruped import legs, stance
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped.balance import BalanceStand, Posture
from wheelleg.controller.quadruped.rotations import rpy_matrix
from wheelleg.controller.quadruped.sensed import Sensed


def _feet_body_for(roll: float, pitch: float, height: float = P.HEIGHT_NOMINAL) -> np.ndarray:
    """Foot centres (body frame) of the nominal footprint on a level floor, the body at (roll, pitch)."""
    return stance.feet_in_body_for_pose(stance.footprint(), np.array([0.0, 0.0, height]), rpy_matrix(roll, pitch))


@pytest.mark.parametrize("roll, pitch", [(0.0, 0.0), (0.17, 0.0), (0.0, -0.17), (-0.1, 0.12)])
def test_the_plane_through_the_feet_gives_the_bodys_roll_and_pitch(roll, pitch):
    assert stance.attitude_over_feet(_feet_body_for(roll, pitch)) == pytest.approx((roll, pitch), abs=1e-9)


def _sensed(roll: float, pitch: float, tilt: tuple[float, float]) -> Sensed:
    q = legs.joints_for_feet(_feet_body_for(roll, pitch))
    zeros = np.zeros((4, 3))
    return Sensed(q=q, qd=zeros, tau=zeros, rpy=np.array([roll + tilt[0], pitch + tilt[1], 0.0]), gyro=np.zeros(3))


def test_the_stand_learns_the_mount_tilt_on_four_feet_and_measures_the_body_without_it():
    tilt = (math.radians(1.4), math.radians(-1.2))
    stand = BalanceStand()
    stand.start(_sensed(0.0, 0.0, tilt))
    for k in range(round(3.0 / stand.period_s)):  # 3 s: six time constants, the body posed at 10 deg of roll
        roll = min(k * stand.period_s, 1.0) * math.radians(10.0)
        stand.step(_sensed(roll, 0.0, tilt), Posture(roll=roll))
    assert stand.mount_tilt == pytest.approx(tilt, abs=math.radians(0.05))
    assert stand.measured[:2] == pytest.approx([math.radians(10.0), 0.0], abs=math.radians(0.05))


def test_a_tilt_beyond_a_mounts_is_not_taken():
    stand = BalanceStand()
    sensed = _sensed(0.0, 0.0, (math.radians(10.0), 0.0))  # a slope or a fault, not a board
    stand.start(sensed)
    for _ in range(round(3.0 / stand.period_s)):
        stand.step(sensed, Posture())
    assert stand.mount_tilt[0] == pytest.approx(P.MOUNT_TILT_LIMIT)


def test_the_trot_trims_a_pitched_body_by_posing_its_stance_feet():
    from wheelleg.controller.quadruped.gait import Trot, Velocity, in_stance, leg_phases

    def trot_for(pitch: float) -> tuple[Trot, np.ndarray]:
        trot = Trot()
        trot.start(_sensed(0.0, 0.0, (0.0, 0.0)))
        sensed = _sensed(0.0, pitch, (0.0, 0.0))
        for _ in range(round(1.0 / trot.period_s)):
            commands = trot.step(sensed, Velocity(), P.HEIGHT_NOMINAL)
        return trot, commands.q

    (level, q_level), (nose_up, q_nose_up) = trot_for(0.0), trot_for(math.radians(-4.0))
    # 1 s at 4 deg: the integral has reached its limit, turning the stance feet nose-down
    assert nose_up.attitude_trim[1] == pytest.approx(P.ATTITUDE_TRIM_LIMIT)
    assert np.abs(level.attitude_trim).max() < 1e-12 and abs(nose_up.attitude_trim[0]) < 1e-12
    stance_legs = in_stance(leg_phases(level.clock))
    assert stance_legs.any()
    assert np.abs(q_nose_up[stance_legs] - q_level[stance_legs]).max() > 0.01  # rad: the stance joints follow it
