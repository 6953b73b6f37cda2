"""The balancer as the rig loads it: the ``Robot`` its entry point (pyproject.toml) names."""
from __future__ import annotations

from pathlib import Path

from wheelleg.dbc import CAN1, CAN2
from wheelleg.hil.record.schemas import POSE_FIELDS, described_schema
from wheelleg.hil.robots import Bus, Device, Robot
from wheelleg_balancer import description as D
from wheelleg_balancer.controller import BUS_FILES, DEBUG_FIELDS, DEVICES, Mode


# MuJoCo, the emulators and the controller load only when a run or a replay builds them
def build_physics(terrain, timestep_s: float, overrides: dict):
    from wheelleg_balancer.physics import BalancerPhysics  # noqa: PLC0415

    return BalancerPhysics(terrain=terrain, timestep_s=timestep_s, overrides=overrides)


def build_plant(physics, buses: dict, rng, config):
    from wheelleg_balancer.plant import BalancerPlant  # noqa: PLC0415

    return BalancerPlant(physics, buses, rng, config)


def build_controller(buses: dict, sync: bool, period_s: float):
    from wheelleg_balancer.controller import BalancerNode  # noqa: PLC0415

    return BalancerNode(buses[CAN1], buses[CAN2], sync=sync, period_s=period_s)


ROBOT = Robot(
    name="balancer",
    summary="two-wheeled self-balancing robot: 2 C620/M3508 wheels, IMU, remote on CAN1, 3.1 kg",
    buses=(
        Bus(CAN1, "wheels, IMU, remote", (*(Device(name, "c620", esc) for name, esc in D.ESC_IDS.items()),
                                          Device("imu", "imu"), Device("remote", "remote")), BUS_FILES[CAN1]),
        Bus(CAN2, "the rig's lockstep frames only", (), BUS_FILES[CAN2]),
    ),
    model_dir=Path(D.MODEL_DIR),
    scenario_modules=("wheelleg_balancer.scenarios",),
    controller_program="wheelleg_balancer.__main__",
    controller_params="wheelleg_balancer.params",
    control_period_s=D.CONTROL_PERIOD_S,
    build_physics=build_physics,
    build_plant=build_plant,
    build_controller=build_controller,
    sim_state_fields=POSE_FIELDS,
    mode_names={int(m): m.name for m in Mode},
    offline_bits=DEVICES,
    debug_schema=described_schema("wheelleg_balancer.Debug", DEBUG_FIELDS),
    # what its plant models: body, IMU, wheel drives, tyres (named like the rig's wheels), bus timing
    plant_override_keys=frozenset({
        "body_mass_scale", "com_x_m", "com_z_m", "inertia_scale", "friction", "wheel_radius_scale",
        "wheel_kt_scale", "imu_tilt_pitch_deg", "imu_tilt_roll_deg", "imu_gyro_bias", "imu_gyro_bias_x",
        "imu_gyro_bias_y", "imu_gyro_bias_z", "imu_noise_scale", "feedback_delay_s", "command_delay_s",
        "supply_voltage_v"}),
)
