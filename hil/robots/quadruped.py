"""The quadruped (the rig's second robot), as a registered ``Robot``.

Twelve CyberGear joints (CyberDog 2 class, 10 kg): bus 0 (``CAN1``) carries
the front legs' motors (ids 1..6), the IMU and the remote (QuadOperator); bus
1 (``CAN2``) the rear legs' (ids 7..12). Its controller is ``python -m
wheelleg.controller.quadruped`` at 4 ms (250 Hz: the bus-load table in
emulators/quadruped/README.md says why). Its plant: emulators/quadruped/.
"""
from __future__ import annotations

from pathlib import Path

from wheelleg.controller.quadruped.modes import Mode
from wheelleg.controller.quadruped.telemetry import DEBUG_FIELDS
from wheelleg.dbc import CAN1, CAN2, QUADRUPED_BUS_FILES
from wheelleg.emulators.quadruped import description as D
from wheelleg.hil.record.schemas import POSE_FIELDS, described_schema
from wheelleg.hil.robots import Bus, Device, Robot

MODEL_DIR = Path(D.__file__).resolve().parent  # emulators/quadruped/: robot.xml, scene.xml


def _motors(bus: int) -> tuple[Device, ...]:
    return tuple(Device(m.name, "cybergear", m.motor_id) for m in D.JOINT_MOTORS if m.bus == bus)


# MuJoCo, the emulators and the controller load only when a run or a replay builds them
def build_physics(terrain, timestep_s: float, overrides: dict):
    from wheelleg.emulators.quadruped.physics import QuadrupedPhysics  # noqa: PLC0415

    return QuadrupedPhysics(terrain=terrain, timestep_s=timestep_s, overrides=overrides)


def build_plant(physics, buses: dict, rng, config):
    from wheelleg.emulators.quadruped.plant import QuadrupedPlant  # noqa: PLC0415

    return QuadrupedPlant(physics, buses, rng, config)


def build_controller(buses: dict, sync: bool, period_s: float):
    from wheelleg.controller.quadruped.node import QuadrupedNode  # noqa: PLC0415

    return QuadrupedNode(buses[CAN1], buses[CAN2], sync=sync, period_s=period_s)


ROBOT = Robot(
    name="quadruped",
    summary="12 CyberGear joints (FR, FL, RR, RL x abduction, thigh, calf), CyberDog 2 class, 10 kg",
    buses=(
        Bus(CAN1, "bus 0: front legs' CyberGears, IMU, remote",
            (*_motors(0), Device("imu", "imu"), Device("remote", "remote")), QUADRUPED_BUS_FILES[CAN1]),
        Bus(CAN2, "bus 1: rear legs' CyberGears", _motors(1), QUADRUPED_BUS_FILES[CAN2]),
    ),
    model_dir=MODEL_DIR,
    scenario_modules=("wheelleg.hil.scenarios.quadruped", "wheelleg.hil.scenarios.quadruped_faults"),
    controller_program="wheelleg.controller.quadruped.__main__",
    controller_params="wheelleg.controller.quadruped.params",
    control_period_s=D.CONTROL_PERIOD_S,
    build_physics=build_physics,
    build_plant=build_plant,
    build_controller=build_controller,
    sim_state_fields={**POSE_FIELDS, "height": "m", **{f"{leg}_foot_force": "N" for leg in D.LEGS},
                      **{f"{leg}_foot_z": "m" for leg in D.LEGS}, "body_on_ground": ""},
    mode_names={int(m): m.name for m in Mode},
    offline_bits=(*(f"{leg} motors" for leg in D.LEGS), "imu", "remote"),  # controller.quadruped.node.heartbeat_mask
    debug_schema=described_schema("wheelleg.QuadrupedControllerDebug", DEBUG_FIELDS),
    plant_override_keys=frozenset({
        "body_mass_scale", "com_x_m", "com_y_m", "com_z_m", "inertia_scale", "imu_tilt_pitch_deg", "imu_tilt_roll_deg",
        "hip_kt_scale", "imu_gyro_bias", "imu_gyro_bias_x", "imu_gyro_bias_y", "imu_gyro_bias_z",
        "imu_noise_scale", "feedback_delay_s", "command_delay_s", "supply_voltage_v"}),
)
