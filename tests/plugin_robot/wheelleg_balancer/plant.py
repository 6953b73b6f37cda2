"""The balancer's plant: two C620/M3508 wheel drives, the IMU and the remote on CAN1, bound to the physics.

The rig's own device emulators (wheelleg.emulators), configured from this
robot's description; CAN2 has no device (the rig's lockstep frames only).
"""
from __future__ import annotations

from wheelleg.dbc import CAN1, CAN2
from wheelleg.emulators.c620 import C620
from wheelleg.emulators.imu import Imu
from wheelleg.emulators.node import DeviceNode
from wheelleg.emulators.plant import motors_in_order, step_motors, sync_shafts
from wheelleg.emulators.remote import Remote
from wheelleg_balancer import description as D


class BalancerPlant:
    """Emulated devices on the balancer's buses, backed by ``physics`` (``BalancerPhysics``)."""

    def __init__(self, physics, buses: dict, rng, config):
        self.physics = physics
        volts = config.value("supply_voltage_v")
        self.wheels = {name: C620(esc_id=esc_id, command_timeout_s=config.esc_command_timeout_s, supply_v=volts,
                                  kt_scale=config.value("wheel_kt_scale"))
                       for name, esc_id in D.ESC_IDS.items()}
        self.imu = Imu(period_s=D.IMU_PERIOD_S, noise=config.true_imu_noise(), rng=rng)
        self.remote = Remote(period_s=D.REMOTE_PERIOD_S)
        delays = {"command_delay_s": config.value("command_delay_s"),
                  "feedback_delay_s": config.value("feedback_delay_s")}
        self.nodes = {CAN1: DeviceNode(buses[CAN1], [*self.wheels.values(), self.imu, self.remote], **delays),
                      CAN2: DeviceNode(buses[CAN2], [], **delays)}
        self._motors = motors_in_order(self.wheels, physics)
        self._dt = physics.model.opt.timestep
        sync_shafts(physics, self._motors, self.imu)

    @property
    def devices(self) -> dict:
        return {**self.wheels, "imu": self.imu, "remote": self.remote}

    def step(self, now_s: float) -> None:
        """One physics step from ``now_s``: the ESCs' torques in, the new state out."""
        step_motors(self.physics, self._motors, self.imu, now_s, self._dt)
