"""The plant: the robot's CAN devices bound to the MuJoCo model.

Four CyberGear emulators drive the hip joints, two C620 emulators the wheels,
an IMU reads the model's sensors and a remote sends the operator's frames.
Each device keeps its own protocol state; the plant only moves torques into
the physics and shaft angles, speeds and IMU truth back out, once per physics
step (1 ms), so the C620s send their feedback at 1 kHz as the real ones do.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import can
import numpy as np

from wheelleg.controller import constants as C
from wheelleg.dbc import CAN1, CAN2
from wheelleg.emulators.c620 import C620
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.imu import Imu, ImuNoise
from wheelleg.emulators.node import DeviceNode
from wheelleg.emulators.physics import Physics
from wheelleg.emulators.remote import Remote


@dataclass
class PlantConfig:
    """What the scenario may choose about the emulated robot."""

    imu_noise: ImuNoise = field(default_factory=ImuNoise)
    esc_command_timeout_s: float | None = None  # None: hold the last current (C620 default)
    imu_period_s: float = 0.002


class Plant:
    """Emulated devices on two buses, backed by ``physics``."""

    def __init__(self, physics: Physics, buses: dict[str, can.BusABC], rng: np.random.Generator,
                 config: PlantConfig | None = None):
        config = config or PlantConfig()
        self.physics = physics
        self.joints = {j.name: CyberGear(motor_id=j.motor_id) for j in C.JOINTS}
        self.wheels = {w.name: C620(esc_id=w.esc_id, command_timeout_s=config.esc_command_timeout_s)
                       for w in C.WHEELS}
        self.imu = Imu(period_s=config.imu_period_s, noise=config.imu_noise, rng=rng)
        self.remote = Remote()
        self.nodes = {
            CAN1: DeviceNode(buses[CAN1], [*self.wheels.values(), self.imu, self.remote]),
            CAN2: DeviceNode(buses[CAN2], list(self.joints.values())),
        }
        self._sync_shafts()

    @property
    def devices(self) -> dict:
        return {**self.joints, **self.wheels, "imu": self.imu, "remote": self.remote}

    def step(self, now_s: float) -> None:
        """One physics step from ``now_s``: device torques in, new state out."""
        hips = {name: dev.output_torque(now_s) for name, dev in self.joints.items()}
        wheels = {name: dev.output_torque(now_s) for name, dev in self.wheels.items()}
        self.physics.set_torques(hips, wheels)
        self.physics.step()
        dt = self.physics.model.opt.timestep
        for dev in (*self.joints.values(), *self.wheels.values()):
            dev.advance(dt, now_s + dt)
        self._sync_shafts()

    def _sync_shafts(self) -> None:
        for name, dev in {**self.joints, **self.wheels}.items():
            dev.shaft.angle, dev.shaft.speed = self.physics.shaft_state(name)
        self.imu.set_truth(*self.physics.imu())
