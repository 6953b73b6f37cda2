"""The imperfections of a real build as plant overrides: each changes the plant, the nominal stays as it was."""
from __future__ import annotations

import math
import uuid

import can
import mujoco
import numpy as np
import pytest

from wheelleg.dbc import CAN1, CAN2, load_file
from wheelleg.dbc import cybergear as cg
from wheelleg.emulators import cybergear
from wheelleg.emulators.drive import TorqueLag, sagged_voltage
from wheelleg.emulators.overrides import OVERRIDES
from wheelleg.emulators.physics import Physics
from wheelleg.emulators.plant import Plant, PlantConfig
from wheelleg.emulators.robot import description as D

NEW_KEYS = ("hip_armature", "wheel_damping", "wheel_frictionloss", "hip_zero_offset_left_front",
            "hip_zero_offset_left_rear", "hip_zero_offset_right_front", "hip_zero_offset_right_rear",
            "hip_kt_scale_left", "hip_kt_scale_right", "wheel_kt_scale_left", "wheel_kt_scale_right",
            "hip_frictionloss_left", "hip_frictionloss_right", "wheel_frictionloss_left",
            "wheel_frictionloss_right", "com_y_m", "battery_resistance_ohm", "hip_torque_lag_s", "wheel_torque_lag_s")
HOST = 0xFD
CG_DB = load_file("cybergear.dbc")


def _model(**overrides) -> mujoco.MjModel:
    return Physics(overrides=PlantConfig.from_overrides(overrides).overrides).model


def _plant(**overrides) -> tuple[Plant, dict]:
    channels = {k: f"imp-{k}-{uuid.uuid4().hex[:8]}" for k in (CAN1, CAN2)}
    buses = {k: can.Bus(interface="virtual", channel=ch) for k, ch in channels.items()}
    hosts = {k: can.Bus(interface="virtual", channel=ch) for k, ch in channels.items()}
    config = PlantConfig.from_overrides(overrides)
    return Plant(Physics(overrides=config.overrides), buses, np.random.default_rng(0), config), hosts


def _joint(m: mujoco.MjModel, name: str, attr: str) -> float:
    return float(getattr(m, attr)[m.jnt_dofadr[m.joint(name).id]])


def test_every_new_key_is_registered_and_its_default_compiles_the_nominal_model_unchanged():
    assert set(NEW_KEYS) <= set(OVERRIDES)
    assert OVERRIDES["hip_armature"].default == pytest.approx(D.CG_ROTOR_INERTIA_KG_M2 * D.CG_GEAR ** 2)
    defaults = {key: OVERRIDES[key].default for key in NEW_KEYS}
    nominal, explicit = Physics(), Physics(overrides=PlantConfig.from_overrides(defaults).overrides)
    assert explicit.spec.to_xml() == nominal.spec.to_xml()
    for attr in ("dof_armature", "dof_damping", "dof_frictionloss", "body_ipos", "body_mass"):
        np.testing.assert_array_equal(getattr(explicit.model, attr), getattr(nominal.model, attr))


@pytest.mark.parametrize("side, other", [("left", "right"), ("right", "left")])
def test_side_frictions_add_to_the_common_one_on_their_side_only(side, other):
    m = _model(hip_frictionloss=0.1, **{f"hip_frictionloss_{side}": 0.2, f"wheel_frictionloss_{side}": 0.05},
               wheel_frictionloss=0.03)
    for name in (f"{side}_front_hip", f"{side}_rear_hip"):
        assert _joint(m, name, "dof_frictionloss") == pytest.approx(0.3)
    for name in (f"{other}_front_hip", f"{other}_rear_hip"):
        assert _joint(m, name, "dof_frictionloss") == pytest.approx(0.1)
    assert _joint(m, f"{side}_wheel", "dof_frictionloss") == pytest.approx(0.08)
    assert _joint(m, f"{other}_wheel", "dof_frictionloss") == pytest.approx(0.03)
    assert _joint(_model(), f"{side}_wheel", "dof_frictionloss") == 0.0


def test_side_torque_constants_multiply_the_common_ones_on_their_side_only():
    plant, _ = _plant(hip_kt_scale=0.9, hip_kt_scale_left=0.8, wheel_kt_scale_right=1.1)
    assert plant.joints["left_front_hip"].kt_scale == pytest.approx(0.72)
    assert plant.joints["left_rear_hip"].kt_scale == pytest.approx(0.72)
    assert plant.joints["right_front_hip"].kt_scale == pytest.approx(0.9)
    assert plant.wheels["right_wheel"].torque_constant == pytest.approx(0.3 * 1.1)
    assert plant.wheels["left_wheel"].torque_constant == pytest.approx(0.3)


def test_com_y_moves_the_body_centre_of_mass_sideways():
    np.testing.assert_allclose(_model(com_y_m=-0.01).body("body").ipos, [0.0, -0.01, 0.0], atol=1e-12)


def _feedback(host_bus: can.BusABC, plant: Plant, motor_id: int, request_type: int, data: bytes = bytes(8)) -> dict:
    host_bus.send(can.Message(arbitration_id=cg.request_id(request_type, HOST, motor_id), data=data,
                              is_extended_id=True))
    plant.nodes[CAN2].service(0.0)
    reply = host_bus.recv(timeout=0)
    return CG_DB.decode_message(reply.arbitration_id & 0x1F000000, reply.data)


@pytest.mark.parametrize("motor", D.HIP_MOTORS, ids=lambda m: m.name)
def test_a_hip_zero_offset_shows_in_the_angle_its_cybergear_reports(motor):
    key = f"hip_zero_offset_{motor.name.removesuffix('_hip')}"
    offset, nominal = _plant(**{key: 0.05}), _plant()
    true_angle = offset[0].joints[motor.name].shaft.angle
    assert true_angle == nominal[0].joints[motor.name].shaft.angle  # the same robot, its belief differs
    reported = _feedback(offset[1][CAN2], offset[0], motor.motor_id, cg.T_FEEDBACK)["Pos"]
    reported_nominal = _feedback(nominal[1][CAN2], nominal[0], motor.motor_id, cg.T_FEEDBACK)["Pos"]
    assert reported == pytest.approx(true_angle - 0.05, abs=1e-3)
    assert reported_nominal == pytest.approx(true_angle, abs=1e-3)
    others = [m for m in D.HIP_MOTORS if m is not motor]
    assert all(offset[0].joints[m.name].mech_pos == offset[0].joints[m.name].shaft.angle for m in others)


def test_a_torque_lag_is_a_first_order_step_response():
    lag = TorqueLag([0.002, 0.0], dt_s=0.001)
    steps = [lag([1.0, 1.0]) for _ in range(6)]
    expected = [1.0 - math.exp(-0.001 * k / 0.002) for k in range(1, 7)]
    np.testing.assert_allclose([s[0] for s in steps], expected, rtol=1e-12)
    assert all(s[1] == 1.0 for s in steps)  # no lag: the command itself


@pytest.mark.parametrize("key, motor, lagged", [("hip_torque_lag_s", "left_front_hip", True),
                                                ("wheel_torque_lag_s", "left_wheel", True),
                                                ("hip_torque_lag_s", "left_wheel", False)])
def test_the_plant_applies_the_lag_to_its_motors_torque(key, motor, lagged):
    plant, _ = _plant(**{key: 0.003})
    device = plant.devices[motor]
    if motor.endswith("hip"):
        device.mode, device.params["run_mode"], device.params["iq_ref"] = cybergear.MODE_RUN, 3, 2.0
    else:
        device.command_raw = 8192  # 10 A
    command = device.output_torque(0.0)
    actuator = plant.physics.model.actuator(motor).id
    plant.step(0.0)
    applied = float(plant.physics.data.ctrl[actuator])
    if lagged:
        assert applied == pytest.approx(command * (1.0 - math.exp(-0.001 / 0.003)), rel=1e-9)
    else:
        assert applied == command


def test_sagged_voltage_solves_the_source_and_its_resistance():
    volts = sagged_voltage(24.0, 0.1, 480.0)
    assert volts * (24.0 - volts) / 0.1 == pytest.approx(480.0)  # V I with I = (E - V) / R
    assert 21.0 < volts < 24.0
    assert sagged_voltage(24.0, 0.1, -100.0) > 24.0  # braking charges the battery
    assert sagged_voltage(24.0, 0.0, 1000.0) == 24.0
    assert sagged_voltage(24.0, 1.0, 1000.0) == 12.0  # beyond what it can give: its maximum-power point


def test_battery_sag_lowers_the_voltage_the_cybergears_report_under_load():
    plant, hosts = _plant(battery_resistance_ohm=0.1, supply_voltage_v=25.0)
    for hip in plant.joints.values():  # 10 A each in current mode: mostly copper loss (the shafts barely move)
        hip.mode, hip.params["run_mode"], hip.params["iq_ref"] = cybergear.MODE_RUN, 3, 10.0
    plant.step(0.0)
    expected = sagged_voltage(25.0, 0.1, 4 * 1.5 * D.CG_LINE_RESISTANCE_OHM * 10.0 ** 2 + sum(
        hip.output_torque(0.0) * hip.shaft.speed for hip in plant.joints.values()))
    read = CG_DB.get_message_by_name("CG_ParamRead")
    index = read.get_signal_by_name("VBUS").multiplexer_ids[0]
    vbus = _feedback(hosts[CAN2], plant, 1, cg.T_PARAM_READ, read.encode({"Index": index, "VBUS": 0},
                                                                          strict=False))["VBUS"]
    assert vbus == pytest.approx(expected, abs=1e-4)
    assert vbus < 25.0 - 1.0  # 270 W of copper loss through 0.1 ohm
    assert plant.wheels["left_wheel"].supply_v == pytest.approx(expected)
    unloaded, _ = _plant(battery_resistance_ohm=0.1, supply_voltage_v=25.0)
    unloaded.step(0.0)
    assert unloaded.joints["left_front_hip"].vbus_v == pytest.approx(25.0, abs=1e-3)


def test_run_accepts_every_new_key(tmp_path):
    from wheelleg.hil.cli import build_parser
    from wheelleg.hil.commands.run import plant_config

    plants = [f"{key}={OVERRIDES[key].low if OVERRIDES[key].default != OVERRIDES[key].low else OVERRIDES[key].high}"
              for key in NEW_KEYS]
    args = build_parser().parse_args(["run", "balance", *(f"--plant={p}" for p in plants)])
    assert set(plant_config(args.plant).overrides_dict()) == set(NEW_KEYS)


def test_the_quadruped_takes_the_sideways_com_and_none_of_the_wheel_legged_robots_parts():
    from wheelleg.emulators.quadruped.physics import QuadrupedPhysics
    from wheelleg.hil import robots

    quadruped = robots.get("quadruped")
    quadruped.check_overrides({"com_y_m": 0.01})
    moved, nominal = QuadrupedPhysics(overrides={"com_y_m": 0.01}).model, QuadrupedPhysics().model
    assert moved.body("body").ipos[1] == pytest.approx(nominal.body("body").ipos[1] + 0.01)
    for key in ("hip_armature", "wheel_frictionloss_left", "hip_zero_offset_left_front", "battery_resistance_ohm"):
        with pytest.raises(ValueError, match=key):
            quadruped.check_overrides({key: OVERRIDES[key].high})
