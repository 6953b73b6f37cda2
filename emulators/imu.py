"""The body IMU on CAN1: rig.dbc's IMU_Orientation, IMU_Gyro and IMU_Accel.

The plant hands it the truth each physics step (``set_truth``); every
``period_s`` of simulated time it sends the three frames, in that order,
with noise and bias added: white noise on rate and specific force, a
constant bias on each, and a small random rotation on the orientation (the
attitude filter's error). Noise comes from the ``rng`` it is given, so a
seeded generator gives the same bytes run after run. Values beyond a field's
range saturate at the field's limits; the quaternion is renormalised after
the noise and rounded to the nearest step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import can
import numpy as np

from wheelleg.dbc import CAN1, load_bus
from wheelleg.dbc.codec import MessageCodec
from wheelleg.emulators.device import EmulatedDevice, PeriodicSchedule, frame
from wheelleg.emulators.robot import description as D

FRAMES = {  # frame -> its signals in the order measure() returns the values
    "IMU_Orientation": ("QuatW", "QuatX", "QuatY", "QuatZ"),
    "IMU_Gyro": ("RateX", "RateY", "RateZ"),
    "IMU_Accel": ("AccX", "AccY", "AccZ"),
}


@dataclass(frozen=True)
class ImuNoise:
    """Noise per sample (1 sigma) and constant biases, body frame.

    Defaults are those of a BMI088-class IMU sampled at 500 Hz (gyro
    0.014 deg/s/sqrt(Hz), accel 160 ug/sqrt(Hz) times sqrt(250 Hz)) and an
    attitude filter good to ~0.1 deg; ``ImuNoise.none()`` is a perfect IMU.
    """

    gyro_std_rad_s: float = 0.004
    gyro_bias_rad_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    accel_std_m_s2: float = 0.025
    accel_bias_m_s2: tuple[float, float, float] = (0.0, 0.0, 0.0)
    attitude_std_rad: float = 0.002
    spike_probability: float = 0.0  # per sample: a gyro axis jumps by +-spike_rad_s (a glitch)
    spike_rad_s: float = 0.0

    @classmethod
    def none(cls) -> "ImuNoise":
        return cls(gyro_std_rad_s=0.0, accel_std_m_s2=0.0, attitude_std_rad=0.0)


def _quat_mul(a: tuple, b: tuple) -> tuple:
    """Hamilton product of two (w, x, y, z) quaternions."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def _small_rotation(rx: float, ry: float, rz: float) -> tuple:
    """Unit quaternion of the rotation vector (rx, ry, rz) rad."""
    angle = math.sqrt(rx * rx + ry * ry + rz * rz)
    if angle < 1e-12:
        return (1.0, 0.0, 0.0, 0.0)
    s = math.sin(angle / 2) / angle
    return (math.cos(angle / 2), rx * s, ry * s, rz * s)


class Imu(EmulatedDevice):
    """The IMU node: talks only, three frames every ``period_s``."""

    def __init__(self, period_s: float = 0.002, noise: ImuNoise | None = None,
                 rng: np.random.Generator | None = None):
        super().__init__()
        self.noise = noise if noise is not None else ImuNoise()
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.period_s = period_s
        self._schedule = PeriodicSchedule(period_s)
        db = load_bus(CAN1)
        self._codecs = [MessageCodec.of(db.get_message_by_name(name)) for name in FRAMES]
        self._payloads = [codec.encoder(dict.fromkeys(names, "rounded")) for codec, names in zip(self._codecs,
                                                                                                 FRAMES.values())]
        self.set_truth((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, D.GRAVITY_M_S2))

    def set_truth(self, quat_wxyz, gyro_body_rad_s, specific_force_body_m_s2) -> None:
        """True orientation (body->world, shape (4,)), rate and specific force (shape (3,) each)."""
        self._quat = tuple(map(float, quat_wxyz))
        self._gyro = tuple(map(float, gyro_body_rad_s))
        self._accel = tuple(map(float, specific_force_body_m_s2))
        if len(self._quat) != 4 or len(self._gyro) != 3 or len(self._accel) != 3:
            raise ValueError("IMU truth needs a (4,) quaternion and (3,) rate and specific force")

    listens = False  # its node skips it when a frame comes (``_handle`` for a direct caller)

    def _handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        return []  # the IMU listens to nobody

    def output_torque(self, now_s: float) -> float:
        return 0.0

    def _periodic(self, now_s: float) -> list[can.Message]:
        if not self._schedule.due(now_s):
            return []
        return [frame(codec.frame_id, payload(*values), False, now_s)
                for codec, payload, values in zip(self._codecs, self._payloads, self.measure())]

    def measure(self) -> tuple[tuple, tuple, tuple]:
        """One noisy sample: quaternion (w, x, y, z), rate rad/s, specific force m/s^2."""
        n = self.noise
        draw = self.rng.standard_normal(9).tolist()
        sigma = n.attitude_std_rad
        quat = _quat_mul(self._quat, _small_rotation(draw[0] * sigma, draw[1] * sigma, draw[2] * sigma))
        # lists, not generators (a sample every tick); the same terms in the same order
        norm = math.sqrt(sum([q * q for q in quat])) or 1.0
        quat = tuple([q / norm for q in quat])
        gyro_std, accel_std = n.gyro_std_rad_s, n.accel_std_m_s2
        gyro = tuple([g + b + gyro_std * d for g, b, d in zip(self._gyro, n.gyro_bias_rad_s, draw[3:6])])
        accel = tuple([a + b + accel_std * d for a, b, d in zip(self._accel, n.accel_bias_m_s2, draw[6:9])])
        if n.spike_probability > 0.0 and self.rng.random() < n.spike_probability:
            gyro = self._spiked(gyro, n.spike_rad_s)
        return quat, gyro, accel

    def _spiked(self, gyro: tuple, magnitude_rad_s: float) -> tuple:
        """``gyro`` with one random axis off by +-``magnitude_rad_s`` (drawn only when spikes are on)."""
        axis, sign = int(self.rng.integers(3)), (1.0 if self.rng.random() < 0.5 else -1.0)
        return tuple(g + sign * magnitude_rad_s if i == axis else g for i, g in enumerate(gyro))
