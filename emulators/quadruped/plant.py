"""The quadruped's plant: its CAN devices bound to its MuJoCo model.

Twelve CyberGear emulators (emulators/cybergear.py, one per joint) drive the
joints, in MIT mode as the quadruped's controller commands them (type-1
position, velocity, Kp, Kd and torque feed-forward, evaluated every physics
step against the shaft); the IMU (emulators/imu.py) reads the model's sensors
at the body centre; the remote sends QuadOperator (dbc/quadruped.dbc).

Wiring (description.JOINT_MOTORS): bus 0 (``CAN1``) carries the FR and FL
motors (ids 1..6), the IMU and the remote; bus 1 (``CAN2``) the RR and RL
motors (ids 7..12). The plant's numbers are its own (description.py); of the per-run overrides it
honours those of the body, the IMU site, the feet's friction and the joints' armature,
damping and dry friction (emulators/model_overrides.py, on all twelve CyberGear joints),
and those of the devices, as the wheel-legged plant applies them to its hips: torque
constant (common and per side), each joint's encoder zero offset, current-loop lag,
supply and its sag under load, IMU noise and bias, latency. The quadruped's registry
entry (wheelleg.hil.robots.quadruped) lists them.
"""
from __future__ import annotations

import can
import numpy as np

from wheelleg.dbc import CAN1, CAN2, load_bus
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.imu import Imu
from wheelleg.emulators.node import DeviceNode
from wheelleg.emulators.plant import PlantConfig, motors_in_order, sag_supply, step_motors, sync_shafts, torque_lag
from wheelleg.emulators.quadruped import description as D
from wheelleg.emulators.quadruped.physics import QuadrupedPhysics
from wheelleg.emulators.remote import Remote

QUAD_OPERATOR = load_bus(CAN1, robot="quadruped").get_message_by_name("QuadOperator")
REMOTE_START = {"Mode": 0, "EStop": 0, "VelX": 0.0, "VelY": 0.0, "YawRate": 0.0, "Height": 0.21,
                "Roll": 0.0, "Pitch": 0.0, "Yaw": 0.0}  # passive, a 0.21 m stand (body centre over the floor)


class QuadrupedPlant:
    """Emulated devices on the quadruped's two buses, backed by ``physics``."""

    def __init__(self, physics: QuadrupedPhysics, buses: dict[str, can.BusABC], rng: np.random.Generator,
                 config: PlantConfig | None = None):
        config = config or PlantConfig()
        self.physics = physics
        volts = config.value("supply_voltage_v")
        self.joints = {m.name: CyberGear(motor_id=m.motor_id, vbus_v=volts, kt_scale=_kt_scale(config, m.leg),
                                         zero_offset_rad=config.value(f"joint_zero_offset_{m.name}"))
                       for m in D.JOINT_MOTORS}
        self.imu = Imu(period_s=config.imu_period_s, noise=config.true_imu_noise(), rng=rng)
        self.remote = Remote(D.REMOTE_PERIOD_S, QUAD_OPERATOR, REMOTE_START)
        delays = {"command_delay_s": config.value("command_delay_s"),
                  "feedback_delay_s": config.value("feedback_delay_s")}
        motors = {bus: [self.joints[m.name] for m in D.JOINT_MOTORS if m.bus == bus] for bus in (0, 1)}
        self.nodes = {
            CAN1: DeviceNode(buses[CAN1], [*motors[0], self.imu, self.remote], **delays),
            CAN2: DeviceNode(buses[CAN2], motors[1], **delays),
        }
        self._motors = motors_in_order(self.joints, physics)
        self._dt = physics.model.opt.timestep  # s, one physics step
        self._lag = torque_lag(config, ["hip_torque_lag_s"] * len(self._motors), self._dt)
        self._battery = (volts, config.value("battery_resistance_ohm"))  # open-circuit V, ohm
        sync_shafts(self.physics, self._motors, self.imu)

    @property
    def devices(self) -> dict:
        return {**self.joints, "imu": self.imu, "remote": self.remote}

    def step(self, now_s: float) -> None:
        """One physics step from ``now_s``: device torques in (through the current loops' lag), new
        state out, the supply sagged by what the motors draw (``battery_resistance_ohm``)."""
        step_motors(self.physics, self._motors, self.imu, now_s, self._dt, self._lag)
        sag_supply(self._motors, *self._battery, now_s + self._dt)


def _kt_scale(config: PlantConfig, leg: str) -> float:
    """A joint's true torque per commanded torque on ``leg``: the common scale times its side's."""
    side = "left" if D.side_sign(leg) > 0 else "right"
    return config.value("hip_kt_scale") * config.value(f"hip_kt_scale_{side}")
