"""The wheel-legged robot (the rig's first and default robot), as a registered ``Robot``.

Two five-bar legs on four CyberGear hip motors (CAN2, ids 1..4), two
C620/M3508 wheel drives (CAN1, ESC ids 1 and 2), the IMU and the remote on
CAN1; its controller is ``python -m wheelleg.controller`` at 2 ms.
"""
from __future__ import annotations

from pathlib import Path

from wheelleg.controller import params as P
from wheelleg.controller.constants import DEVICES
from wheelleg.controller.modes import Mode
from wheelleg.controller.node import ControllerNode
from wheelleg.controller.telemetry import DEBUG_FIELDS
from wheelleg.dbc import BUS_FILES, CAN1, CAN2
from wheelleg.emulators.robot import description as D
from wheelleg.hil.record.schemas import SIM_STATE_FIELDS, described_schema
from wheelleg.hil.robots import Bus, Device, Robot

MODEL_DIR = Path(D.__file__).resolve().parent  # emulators/robot/: robot.xml, scene.xml


# MuJoCo and the emulators load only when a run builds them (replay and inspect need neither)
def build_physics(terrain, timestep_s: float, overrides: dict):
    from wheelleg.emulators.physics import Physics  # noqa: PLC0415

    return Physics(terrain=terrain, timestep_s=timestep_s, overrides=overrides)


def build_plant(physics, buses: dict, rng, config):
    from wheelleg.emulators.plant import Plant  # noqa: PLC0415

    return Plant(physics, buses, rng, config)


def build_controller(buses: dict, sync: bool, period_s: float) -> ControllerNode:
    return ControllerNode(buses[CAN1], buses[CAN2], sync=sync, period_s=period_s)


ROBOT = Robot(
    name="wheel-legged",
    summary="two five-bar legs with wheels: 4 CyberGear hips, 2 C620/M3508 wheels, 4.6 kg",
    buses=(
        Bus(CAN1, "wheels, IMU, remote",
            (*(Device(w.name, "c620", w.esc_id) for w in D.WHEEL_DRIVES), Device("imu", "imu"),
             Device("remote", "remote")), BUS_FILES[CAN1]),
        Bus(CAN2, "CyberGear hip motors", tuple(Device(m.name, "cybergear", m.motor_id) for m in D.HIP_MOTORS),
            BUS_FILES[CAN2]),
    ),
    model_dir=MODEL_DIR,
    scenario_modules=tuple(f"wheelleg.hil.scenarios.{m}" for m in ("basic", "airborne", "collisions", "ground",
                                                                   "faults")),
    controller_program="wheelleg.controller.__main__",
    controller_params="wheelleg.controller.params",
    control_period_s=P.CONTROL_PERIOD,
    build_physics=build_physics,
    build_plant=build_plant,
    build_controller=build_controller,
    sim_state_fields=SIM_STATE_FIELDS,
    mode_names={int(m): m.name for m in Mode},
    offline_bits=tuple(DEVICES),
    debug_schema=described_schema("wheelleg.ControllerDebug", DEBUG_FIELDS),
)
