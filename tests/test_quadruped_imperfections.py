"""The quadruped's actuator imperfections as plant overrides: each changes its plant, the nominal stays as it was.

The same keys as the wheel-legged robot's hips where the meaning is the same
(``hip_*``: every CyberGear joint, here all twelve; left = FL and RL), plus
``joint_armature_scale`` and a ``joint_zero_offset_*`` per joint.
"""
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
from wheelleg.emulators.drive import sagged_voltage
from wheelleg.emulators.overrides import OVERRIDES, check_override
from wheelleg.emulators.plant import PlantConfig
from wheelleg.emulators.quadruped import description as D
from wheelleg.emulators.quadruped.physics import QuadrupedPhysics
from wheelleg.emulators.quadruped.plant import QuadrupedPlant
from wheelleg.hil import robots
from wheelleg.hil.campaign.sampling import PRESETS

HOST = 0xFD
CG_DB = load_file("cybergear.dbc")
QUAD = robots.get("quadruped")
NEW_KEYS = ("joint_armature_scale", "hip_damping", "hip_frictionloss", "hip_frictionloss_left",
            "hip_frictionloss_right", "hip_kt_scale_left", "hip_kt_scale_right", "hip_torque_lag_s",
            "battery_resistance_ohm", "friction", *(f"joint_zero_offset_{m.name}" for m in D.JOINT_MOTORS))
LEFT = tuple(m.name for m in D.JOINT_MOTORS if m.leg in ("FL", "RL"))
RIGHT = tuple(m.name for m in D.JOINT_MOTORS if m.leg in ("FR", "RR"))


def _model(**overrides) -> mujoco.MjModel:
    return QuadrupedPhysics(overrides=PlantConfig.from_overrides(overrides).overrides).model


def _plant(**overrides) -> tuple[QuadrupedPlant, dict]:
    channels = {k: f"quad-imp-{k}-{uuid.uuid4().hex[:8]}" for k in (CAN1, CAN2)}
    buses = {k: can.Bus(interface="virtual", channel=ch) for k, ch in channels.items()}
    hosts = {k: can.Bus(interface="virtual", channel=ch) for k, ch in channels.items()}
    config = PlantConfig.from_overrides(overrides)
    physics = QuadrupedPhysics(overrides=config.overrides)
    physics.reset_standing(0.21)
    return QuadrupedPlant(physics, buses, np.random.default_rng(0), config), hosts


def _dof(m: mujoco.MjModel, joint: str, attr: str) -> float:
    return float(getattr(m, attr)[m.jnt_dofadr[m.joint(joint).id]])


def _feedback(hosts: dict, plant: QuadrupedPlant, motor: D.JointMotor, request_type: int,
              data: bytes = bytes(8)) -> dict:
    role = CAN1 if motor.bus == 0 else CAN2
    hosts[role].send(can.Message(arbitration_id=cg.request_id(request_type, HOST, motor.motor_id), data=data,
                                 is_extended_id=True))
    plant.nodes[role].service(0.0)
    while (reply := hosts[role].recv(timeout=0)) is not None:
        if reply.arbitration_id & 0xFF00 == motor.motor_id << 8:
            return CG_DB.decode_message(reply.arbitration_id & 0x1F000000, reply.data)
    raise AssertionError(f"no reply from {motor.name}")


def test_the_quadruped_takes_every_new_key_and_their_defaults_compile_its_model_unchanged():
    assert set(NEW_KEYS) <= QUAD.plant_override_keys
    defaults = {key: OVERRIDES[key].default for key in NEW_KEYS}
    nominal, explicit = QuadrupedPhysics(), QuadrupedPhysics(overrides=PlantConfig.from_overrides(defaults).overrides)
    assert explicit.spec.to_xml() == nominal.spec.to_xml()
    for attr in ("dof_armature", "dof_damping", "dof_frictionloss", "geom_friction", "body_mass"):
        np.testing.assert_array_equal(getattr(explicit.model, attr), getattr(nominal.model, attr))


def test_joint_armature_scale_multiplies_every_joints_reflected_inertia():
    m, nominal = _model(joint_armature_scale=4.0), _model()
    for motor in D.JOINT_MOTORS:
        described = _dof(nominal, motor.name, "dof_armature")
        assert described == pytest.approx(D.JOINT_ARMATURE_KG_M2, rel=1e-4)  # robot.xml: 0.002871
        assert _dof(m, motor.name, "dof_armature") == pytest.approx(4.0 * described, rel=1e-12)


@pytest.mark.parametrize("side, own, other", [("left", LEFT, RIGHT), ("right", RIGHT, LEFT)])
def test_dry_friction_adds_to_the_described_one_and_a_side_key_to_its_legs_only(side, own, other):
    m = _model(hip_frictionloss=0.05, **{f"hip_frictionloss_{side}": 0.2})
    for name in own:
        assert _dof(m, name, "dof_frictionloss") == pytest.approx(D.JOINT_FRICTION_NM + 0.25)
    for name in other:
        assert _dof(m, name, "dof_frictionloss") == pytest.approx(D.JOINT_FRICTION_NM + 0.05)


def test_damping_adds_to_the_described_one_on_every_joint():
    m = _model(hip_damping=0.004)
    for motor in D.JOINT_MOTORS:
        assert _dof(m, motor.name, "dof_damping") == pytest.approx(D.JOINT_DAMPING_NM_S_PER_RAD + 0.004)


def test_friction_changes_the_feet_and_the_floor():
    m, nominal = _model(friction=0.5), _model()
    for leg in D.LEGS:
        assert m.geom_friction[m.geom(f"{leg}_foot").id][0] == 0.5
        assert nominal.geom_friction[nominal.geom(f"{leg}_foot").id][0] == D.FRICTION
    assert m.geom_friction[m.geom("floor").id][0] == 0.5


@pytest.mark.parametrize("motor", D.JOINT_MOTORS, ids=lambda m: m.name)
def test_a_joint_zero_offset_shows_in_the_angle_its_cybergear_reports_and_in_no_other(motor):
    (offset, offset_hosts), (nominal, nominal_hosts) = _plant(**{f"joint_zero_offset_{motor.name}": 0.05}), _plant()
    true_angle = offset.joints[motor.name].shaft.angle
    assert true_angle == nominal.joints[motor.name].shaft.angle  # the same robot, its belief differs
    reported = _feedback(offset_hosts, offset, motor, cg.T_FEEDBACK)["Pos"]
    assert reported == pytest.approx(true_angle - 0.05, abs=1e-3)
    assert _feedback(nominal_hosts, nominal, motor, cg.T_FEEDBACK)["Pos"] == pytest.approx(true_angle, abs=1e-3)
    others = [m for m in D.JOINT_MOTORS if m is not motor]
    assert all(offset.joints[m.name].mech_pos == offset.joints[m.name].shaft.angle for m in others)


def test_side_torque_constants_scale_their_legs_joints_only():
    plant, _ = _plant(hip_kt_scale=0.9, hip_kt_scale_left=0.95)
    for name in LEFT:
        assert plant.joints[name].kt_scale == pytest.approx(0.9 * 0.95)
    for name in RIGHT:
        assert plant.joints[name].kt_scale == pytest.approx(0.9)


def _torque_mode(joint: cybergear.CyberGear, amps: float) -> None:
    joint.mode, joint.params["run_mode"], joint.params["iq_ref"] = cybergear.MODE_RUN, 3, amps


def test_the_current_loop_lag_delays_every_joints_torque():
    lagged, _ = _plant(hip_torque_lag_s=0.003)
    plain, _ = _plant()
    for plant in (lagged, plain):
        for joint in plant.joints.values():
            _torque_mode(joint, 2.0)
        plant.step(0.0)
    for motor in D.JOINT_MOTORS:
        command = plain.joints[motor.name].output_torque(0.0)
        actuator = lagged.physics.model.actuator(motor.name).id
        assert float(plain.physics.data.ctrl[actuator]) == command != 0.0
        assert float(lagged.physics.data.ctrl[actuator]) == pytest.approx(
            command * (1.0 - math.exp(-0.001 / 0.003)), rel=1e-9)


def test_battery_sag_lowers_the_voltage_the_joints_report_under_load():
    plant, hosts = _plant(battery_resistance_ohm=0.1, supply_voltage_v=25.0)
    for joint in plant.joints.values():
        _torque_mode(joint, 10.0)
    plant.step(0.0)
    read = CG_DB.get_message_by_name("CG_ParamRead")
    index = read.get_signal_by_name("VBUS").multiplexer_ids[0]
    request = read.encode({"Index": index, "VBUS": 0}, strict=False)
    rear = next(m for m in D.JOINT_MOTORS if m.bus == 1)
    vbus = _feedback(hosts, plant, rear, cg.T_PARAM_READ, request)["VBUS"]
    expected = sagged_voltage(25.0, 0.1, sum(j.supply_power_w(0.001) for j in plant.joints.values()))
    assert vbus < 25.0 - 2.0  # twelve joints at 10 A through 0.1 ohm
    assert vbus == pytest.approx(plant.joints["FR_thigh"].vbus_v, abs=1e-3)
    assert plant.joints["FR_thigh"].vbus_v == pytest.approx(expected, rel=0.05)
    unloaded, _ = _plant(battery_resistance_ohm=0.1, supply_voltage_v=25.0)
    unloaded.step(0.0)
    assert unloaded.joints["FR_thigh"].vbus_v == pytest.approx(25.0, abs=1e-3)


def test_the_quadruped_box_is_its_own_keys_within_their_ranges():
    box = PRESETS["quadruped-tolerance"]
    assert set(box) <= QUAD.plant_override_keys
    for key, (low, high) in box.items():
        assert check_override(key, low) <= check_override(key, high)  # ValueError outside its range
    assert all(f"joint_zero_offset_{m.name}" in box for m in D.JOINT_MOTORS)
    assert not set(box) & {"hip_armature", "wheel_frictionloss_left", "hip_zero_offset_left_front"}
