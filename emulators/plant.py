"""The plant: the robot's CAN devices bound to the MuJoCo model.

Four CyberGear emulators drive the hip joints, two C620 emulators the wheels,
an IMU reads the model's sensors and a remote sends the operator's frames.
Each device keeps its own protocol state; the plant only moves torques into
the physics and shaft angles, speeds and IMU truth back out, once per physics
step (1 ms), so the C620s send their feedback at 1 kHz as the real ones do.

The plant's numbers are its own (emulators/robot/description.py), never the
controller's; ``PlantConfig.overrides`` moves them per run (the keys and their
ranges: ``OVERRIDES``, emulators/overrides.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Mapping

import can
import numpy as np

from wheelleg.dbc import CAN1, CAN2
from wheelleg.emulators.c620 import C620
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.emulators.drive import TorqueLag, sagged_voltage
from wheelleg.emulators.imu import Imu, ImuNoise
from wheelleg.emulators.node import DeviceNode
from wheelleg.emulators.overrides import OVERRIDES, check_overrides
from wheelleg.emulators.physics import Physics
from wheelleg.emulators.remote import Remote
from wheelleg.emulators.robot import description as D

__all__ = ["CAN1", "CAN2", "OVERRIDES", "Plant", "PlantConfig"]


@dataclass
class PlantConfig:
    """What the scenario may choose about the emulated robot."""

    imu_noise: ImuNoise = field(default_factory=ImuNoise)
    esc_command_timeout_s: float | None = None  # None: hold the last current (C620 default)
    imu_period_s: float = 0.002
    overrides: dict[str, float] = field(default_factory=dict)  # key of OVERRIDES -> value (its unit)

    def __post_init__(self):
        self.overrides = check_overrides(self.overrides)

    @classmethod
    def from_overrides(cls, mapping: Mapping[str, str | float]) -> "PlantConfig":
        """A config with these overrides (strings or numbers); ValueError (one line) for an
        unknown key or a value outside its range."""
        return cls(overrides=dict(mapping))

    def overrides_dict(self) -> dict[str, float]:
        """The overrides that differ from their defaults, key -> float (JSON-able)."""
        return {k: v for k, v in self.overrides.items() if v != OVERRIDES[k].default}

    def value(self, key: str) -> float:
        """The true value of override ``key`` in this run: the override, else its default."""
        return self.overrides.get(key, OVERRIDES[key].default)

    def true_imu_noise(self) -> ImuNoise:
        """``imu_noise`` with the IMU overrides applied (noise scale, gyro bias per axis)."""
        if not any(k.startswith("imu_gyro_bias") or k == "imu_noise_scale" for k in self.overrides_dict()):
            return self.imu_noise
        scale, bias = self.value("imu_noise_scale"), self.value("imu_gyro_bias")
        n = self.imu_noise
        return replace(n, gyro_std_rad_s=n.gyro_std_rad_s * scale, accel_std_m_s2=n.accel_std_m_s2 * scale,
                       attitude_std_rad=n.attitude_std_rad * scale,
                       gyro_bias_rad_s=tuple(b + bias + self.value(f"imu_gyro_bias_{axis}")
                                             for b, axis in zip(n.gyro_bias_rad_s, "xyz")))


def motors_in_order(motors: Mapping[str, object], physics) -> tuple:
    """The motor devices of ``motors`` (name -> device) in the physics' ``MOTORS`` order, which
    their names must be in (the per-step path sets and reads the motors by position)."""
    if tuple(motors) != physics.MOTORS:
        raise ValueError(f"the plant's motors {tuple(motors)} are not the physics' {physics.MOTORS}")
    return tuple(motors.values())


def step_motors(physics, motors, imu, now_s: float, dt_s: float, lag: TorqueLag | None = None) -> None:
    """One physics step of a plant from ``now_s`` (s), ``dt_s`` long: each motor device's torque
    in (``motors``, in the physics' ``MOTORS`` order; through ``lag`` when given), the step, the
    devices advanced to its end, their shafts and the IMU's truth read back (``sync_shafts``)."""
    torques = [dev.output_torque(now_s) for dev in motors]
    physics.set_motor_torques(torques if lag is None else lag(torques))
    physics.step()
    end_s = now_s + dt_s
    for dev in motors:
        dev.advance(dt_s, end_s)
    sync_shafts(physics, motors, imu)


def sync_shafts(physics, motors, imu) -> None:
    """Each motor device's shaft (angle, speed) and the IMU's truth from the physics' state."""
    for dev, (angle, speed) in zip(motors, physics.motor_states()):
        shaft = dev.shaft
        shaft.angle, shaft.speed = angle, speed
    imu.set_truth(*physics.imu_truth())


class Plant:
    """Emulated devices on two buses, backed by ``physics``."""

    def __init__(self, physics: Physics, buses: dict[str, can.BusABC], rng: np.random.Generator,
                 config: PlantConfig | None = None):
        config = config or PlantConfig()
        self.physics = physics
        volts = config.value("supply_voltage_v")
        self.joints = {m.name: CyberGear(motor_id=m.motor_id, vbus_v=volts,
                                         kt_scale=config.value("hip_kt_scale") * config.value(f"hip_kt_scale_{m.leg}"),
                                         zero_offset_rad=config.value(f"hip_zero_offset_{m.name.removesuffix('_hip')}"))
                       for m in D.HIP_MOTORS}
        self.wheels = {w.name: C620(esc_id=w.esc_id, command_timeout_s=config.esc_command_timeout_s, supply_v=volts,
                                    kt_scale=config.value("wheel_kt_scale") * config.value(f"wheel_kt_scale_{w.leg}"))
                       for w in D.WHEEL_DRIVES}
        self.imu = Imu(period_s=config.imu_period_s, noise=config.true_imu_noise(), rng=rng)
        self.remote = Remote()
        delays = {"command_delay_s": config.value("command_delay_s"),
                  "feedback_delay_s": config.value("feedback_delay_s")}
        self.nodes = {
            CAN1: DeviceNode(buses[CAN1], [*self.wheels.values(), self.imu, self.remote], **delays),
            CAN2: DeviceNode(buses[CAN2], list(self.joints.values()), **delays),
        }
        self._motors = motors_in_order({**self.joints, **self.wheels}, physics)
        self._dt = physics.model.opt.timestep  # s, one physics step
        self._lag = torque_lag(config, ["hip_torque_lag_s" if isinstance(dev, CyberGear) else "wheel_torque_lag_s"
                                        for dev in self._motors], self._dt)
        self._battery = (volts, config.value("battery_resistance_ohm"))  # open-circuit V, ohm
        sync_shafts(self.physics, self._motors, self.imu)

    @property
    def devices(self) -> dict:
        return {**self.joints, **self.wheels, "imu": self.imu, "remote": self.remote}

    def step(self, now_s: float) -> None:
        """One physics step from ``now_s``: device torques in, new state out, the supply sagged
        by what the motors draw (``battery_resistance_ohm``)."""
        step_motors(self.physics, self._motors, self.imu, now_s, self._dt, self._lag)
        open_circuit_v, resistance = self._battery
        if resistance:
            end_s = now_s + self._dt
            volts = sagged_voltage(open_circuit_v, resistance, sum(dev.supply_power_w(end_s) for dev in self._motors))
            for dev in self._motors:
                dev.set_supply_voltage(volts)


def torque_lag(config: PlantConfig, keys: list[str], dt_s: float) -> TorqueLag | None:
    """The lag of each motor (its override key in ``keys``, motor order), None when every one is 0."""
    constants = [config.value(key) for key in keys]
    return TorqueLag(constants, dt_s) if any(constants) else None
