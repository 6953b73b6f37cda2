"""Per-run plant overrides: the registry, validation, and that each really changes the plant."""
from __future__ import annotations

import json
import math

import pytest

from wheelleg.emulators.plant import OVERRIDES, PlantConfig

REQUIRED = ("body_mass_scale", "com_x_m", "com_z_m", "inertia_scale", "friction", "wheel_radius_scale",
            "hip_kt_scale", "wheel_kt_scale", "hip_damping", "hip_frictionloss", "imu_tilt_pitch_deg",
            "imu_tilt_roll_deg", "imu_gyro_bias", "imu_gyro_bias_x", "imu_gyro_bias_y", "imu_gyro_bias_z",
            "imu_noise_scale", "feedback_delay_s", "command_delay_s", "supply_voltage_v")


def test_registry_has_every_required_key_with_a_sane_spec():
    assert set(REQUIRED) <= set(OVERRIDES)
    for key, spec in OVERRIDES.items():
        assert spec.low <= spec.default <= spec.high, key
        assert spec.description and "\n" not in spec.description, key


def test_from_overrides_takes_strings_and_numbers():
    config = PlantConfig.from_overrides({"com_x_m": "0.02", "friction": 0.4, "supply_voltage_v": "24"})
    assert config.value("com_x_m") == 0.02 and config.value("friction") == 0.4
    assert config.value("hip_damping") == 0.0  # untouched: the default
    assert config.overrides_dict() == {"com_x_m": 0.02, "friction": 0.4}  # 24 V is the default
    assert json.loads(json.dumps(config.overrides_dict())) == config.overrides_dict()
    assert PlantConfig().overrides_dict() == {}


@pytest.mark.parametrize("mapping, words", [
    ({"com_w_m": 0.01}, ["unknown plant override 'com_w_m'", "com_x_m", "supply_voltage_v"]),
    ({"com_x_m": 0.5}, ["com_x_m", "impossible", "-0.1..0.1 m"]),
    ({"friction": "abc"}, ["friction", "not a number"]),
    ({"friction": math.nan}, ["friction", "impossible"]),
    ({"supply_voltage_v": 48}, ["supply_voltage_v", "16..28 V"]),
    ({"feedback_delay_s": -0.001}, ["feedback_delay_s", "impossible"]),
])
def test_a_bad_override_is_a_one_line_error(mapping, words):
    with pytest.raises(ValueError) as info:
        PlantConfig.from_overrides(mapping)
    message = str(info.value)
    assert "\n" not in message
    for word in words:
        assert word in message


def test_a_config_built_directly_is_checked_too():
    with pytest.raises(ValueError, match="impossible"):
        PlantConfig(overrides={"body_mass_scale": 0.0})


# --- each override changes the plant ------------------------------------------------------------
import argparse  # noqa: E402
import uuid  # noqa: E402

import can  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from wheelleg.dbc import load_file  # noqa: E402
from wheelleg.emulators import cybergear  # noqa: E402
from wheelleg.emulators.physics import Physics, euler_zyx  # noqa: E402
from wheelleg.dbc import CAN1, CAN2  # noqa: E402
from wheelleg.emulators.plant import Plant  # noqa: E402
from wheelleg.emulators.robot import description as D  # noqa: E402

C620_DB = load_file("c620.dbc")
HIPS = [m.name for m in D.HIP_MOTORS]
WHEELS = [w.name for w in D.WHEEL_DRIVES]


def _model(**overrides) -> mujoco.MjModel:
    return Physics(overrides=PlantConfig.from_overrides(overrides).overrides).model


def _plant(**overrides) -> tuple[Plant, dict]:
    channels = {k: f"ovr-{k}-{uuid.uuid4().hex[:8]}" for k in (CAN1, CAN2)}
    buses = {k: can.Bus(interface="virtual", channel=ch) for k, ch in channels.items()}
    hosts = {k: can.Bus(interface="virtual", channel=ch) for k, ch in channels.items()}
    config = PlantConfig.from_overrides(overrides)
    return Plant(Physics(overrides=config.overrides), buses, np.random.default_rng(0), config), hosts


NOMINAL = _model()


def _dof(m, joint: str) -> int:
    return int(m.jnt_dofadr[m.joint(joint).id])


@pytest.mark.parametrize("key, value, read", [
    ("body_mass_scale", 1.3, lambda m: (m.body("body").mass[0], m.body("body").inertia[1])),
    ("inertia_scale", 1.5, lambda m: (m.body("body").mass[0], m.body("body").inertia[1])),
    ("com_x_m", 0.02, lambda m: m.body("body").ipos[0]),
    ("com_z_m", -0.01, lambda m: m.body("body").ipos[2]),
    ("friction", 0.4, lambda m: (m.geom("floor").friction[0], m.geom("left_wheel").friction[0])),
    ("wheel_radius_scale", 1.1, lambda m: m.geom("right_wheel").size[0]),
    ("hip_damping", 0.2, lambda m: m.dof_damping[_dof(m, "left_rear_hip")]),
    ("hip_frictionloss", 0.3, lambda m: m.dof_frictionloss[_dof(m, "right_front_hip")]),
    ("com_y_m", 0.01, lambda m: m.body("body").ipos[1]),
    ("hip_armature", 0.014, lambda m: [m.dof_armature[_dof(m, name)] for name in HIPS]),
    ("wheel_damping", 0.004, lambda m: [m.dof_damping[_dof(m, name)] for name in WHEELS]),
    ("wheel_frictionloss", 0.1, lambda m: [m.dof_frictionloss[_dof(m, name)] for name in WHEELS]),
])
def test_model_overrides_change_the_compiled_model(key, value, read):
    nominal, changed = np.atleast_1d(read(NOMINAL)), np.atleast_1d(read(_model(**{key: value})))
    expected = {
        "body_mass_scale": lambda: [D.MASS_BODY_KG * 1.3, nominal[1] * 1.3],
        "inertia_scale": lambda: [D.MASS_BODY_KG, nominal[1] * 1.5],
        "friction": lambda: [0.4, 0.4], "wheel_radius_scale": lambda: [D.WHEEL_RADIUS_M * 1.1],
        "hip_armature": lambda: [0.014] * 4, "wheel_damping": lambda: [0.004] * 2,
        "wheel_frictionloss": lambda: [0.1] * 2,
    }.get(key, lambda: [value])()
    np.testing.assert_allclose(changed, expected, rtol=1e-12)
    assert not np.allclose(changed, nominal)


@pytest.mark.parametrize("key, axis", [("imu_tilt_pitch_deg", 1), ("imu_tilt_roll_deg", 0)])
def test_imu_tilt_shows_in_the_imu_reading_of_a_level_body(key, axis):
    phys = Physics(overrides=PlantConfig.from_overrides({key: 3.0}).overrides)
    phys.reset_standing()
    quat, _, _ = phys.imu()
    assert math.degrees(euler_zyx(quat)[axis]) == pytest.approx(3.0, abs=1e-6)
    assert math.degrees(euler_zyx(quat)[1 - axis]) == pytest.approx(0.0, abs=1e-6)
    assert phys.ground_truth()["pitch"] == 0.0 and phys.ground_truth()["roll"] == 0.0  # the body is level
    nominal = Physics()
    nominal.reset_standing()
    np.testing.assert_allclose(nominal.imu()[0], [1.0, 0.0, 0.0, 0.0], atol=1e-12)


def test_imu_bias_and_noise_scale_reach_the_imu():
    plant, _ = _plant(imu_gyro_bias=0.05, imu_gyro_bias_y=0.1, imu_noise_scale=5.0)
    noise = plant.imu.noise
    assert noise.gyro_bias_rad_s == pytest.approx((0.05, 0.15, 0.05))
    plant.imu.set_truth((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 9.81))
    rates = np.array([plant.imu.measure()[1] for _ in range(3000)])
    np.testing.assert_allclose(rates.mean(axis=0), (0.05, 0.15, 0.05), atol=0.002)
    assert rates[:, 0].std() == pytest.approx(5 * 0.004, rel=0.1)  # 5 x the BMI088-class 0.004 rad/s


def test_hip_kt_scale_scales_the_shaft_torque_not_the_reported_one():
    plant, _ = _plant(hip_kt_scale=0.85)
    motor = plant.joints["left_front_hip"]
    motor.mode, motor.params["run_mode"], motor.params["iq_ref"] = cybergear.MODE_RUN, 3, 2.0
    believed = 2.0 * D.CG_TORQUE_CONSTANT_NM_PER_A
    assert motor.firmware_torque() == pytest.approx(believed)
    assert motor.output_torque(0.0) == pytest.approx(0.85 * believed)


def test_wheel_kt_scale_scales_the_torque_per_amp():
    plant, _ = _plant(wheel_kt_scale=1.15)
    esc = plant.wheels["left_wheel"]
    esc.command_raw = 8192  # 10 A
    assert esc.output_torque(0.0) == pytest.approx(10.0 * 0.3 * 1.15)
    fb = C620_DB.decode_message(esc.feedback_frame(0.0).arbitration_id, esc.feedback_frame(0.0).data)
    assert fb["TorqueCurrent"] == pytest.approx(10.0, abs=0.01)  # the ESC reports amps, not torque


def test_supply_voltage_moves_both_motors_speed_limits_and_the_reported_vbus():
    low, _ = _plant(supply_voltage_v=20.0)
    nominal, _ = _plant()
    for plant in (low, nominal):
        motor, esc = plant.joints["right_rear_hip"], plant.wheels["right_wheel"]
        motor.mode, motor.params["run_mode"], motor.params["iq_ref"] = cybergear.MODE_RUN, 3, 10.0
        motor.shaft.speed = 26.0  # rad/s: beyond 30 x 20/24 = 25 rad/s
        esc.command_raw, esc.shaft.speed = 8192, 47.0  # rad/s: 482 rpm x 20/24 = 42 rad/s
    assert low.joints["right_rear_hip"].output_torque(0.0) == 0.0
    assert nominal.joints["right_rear_hip"].output_torque(0.0) > 5.0
    assert low.wheels["right_wheel"].output_torque(0.0) == 0.0
    assert nominal.wheels["right_wheel"].output_torque(0.0) > 1.0
    assert low.joints["right_rear_hip"].vbus_v == 20.0


def _received(bus: can.BusABC) -> list[can.Message]:
    out = []
    while (msg := bus.recv(timeout=0)) is not None:
        out.append(msg)
    return out


def test_feedback_delay_holds_device_frames_back():
    plant, hosts = _plant(feedback_delay_s=0.002)
    node = plant.nodes[CAN1]
    node.service(0.0)
    assert _received(hosts[CAN1]) == []
    node.service(0.001)
    assert _received(hosts[CAN1]) == []
    node.service(0.002)  # what the devices made at t = 0 goes out now
    ids = [m.arbitration_id for m in _received(hosts[CAN1])]
    assert 0x201 in ids and 0x202 in ids
    nominal, hosts = _plant()
    nominal.nodes[CAN1].service(0.0)
    assert 0x201 in [m.arbitration_id for m in _received(hosts[CAN1])]


def test_command_delay_holds_controller_frames_back():
    plant, hosts = _plant(command_delay_s=0.002)
    cmd = C620_DB.get_message_by_name("C620_Cmd_1_4")
    data = cmd.encode({"ESC1_Current": 5.0, "ESC2_Current": 0.0, "ESC3_Current": 0.0, "ESC4_Current": 0.0})
    hosts[CAN1].send(can.Message(arbitration_id=cmd.frame_id, data=data, is_extended_id=False))
    esc = plant.wheels["left_wheel"]
    plant.nodes[CAN1].service(0.0)
    plant.nodes[CAN1].service(0.001)
    assert esc.command_raw == 0
    plant.nodes[CAN1].service(0.002)
    assert esc.commanded_current(0.002) == pytest.approx(5.0, abs=0.01)


# --- a run on a changed plant: recorded, replayed, rerun ----------------------------------------
def _run(out, plant: list[str]):
    from wheelleg.hil.commands.run import execute

    args = argparse.Namespace(scenario="balance", out=out, interface="virtual", channel=["vcan0", "vcan1"], seed=3,
                              duration=0.4, realtime=False, external_controller=False, no_plot=True, plant=plant)
    outcome, _, _ = execute(args)
    return outcome


def test_a_run_records_its_overrides_and_replays_identically(tmp_path):
    from wheelleg.hil.record.run_metadata import plant_overrides, rerun_command
    from wheelleg.hil.analyze.replay import replay
    from wheelleg.hil.record.sources import open_recording as open_trace

    changed = _run(tmp_path / "changed", ["com_x_m=0.02", "feedback_delay_s=0.002", "supply_voltage_v=24"])
    nominal = _run(tmp_path / "nominal", [])
    assert changed.log_path.read_bytes() != nominal.log_path.read_bytes()  # the plant did change
    source = open_trace(changed.trace_path)
    run = source.run
    assert b'<inertial pos="0.02 0 0"' in source.attachments["plant_model.xml"]
    assert "plant_model.xml" not in open_trace(nominal.trace_path).attachments
    assert plant_overrides(run) == {"com_x_m": 0.02, "feedback_delay_s": 0.002}  # defaults left out
    assert plant_overrides(open_trace(nominal.trace_path).run) == {}
    assert rerun_command(run) == ("wheelleg run balance --seed 3 --duration 0.4 "
                                  "--plant com_x_m=0.02 --plant feedback_delay_s=0.002")
    result = replay(changed.trace_path)
    assert result.identical and result.ticks == 200
    assert any("--plant com_x_m=0.02" in note for note in result.notes)
    again = _run(tmp_path / "again", ["com_x_m=0.02", "feedback_delay_s=0.002"])  # what the rerun command does
    assert again.log_path.read_bytes() == changed.log_path.read_bytes()


def test_run_rejects_a_bad_override_in_one_line(tmp_path, capsys):
    from wheelleg.hil.cli import main

    assert main(["run", "balance", "--plant", "mass=2", "--out", str(tmp_path), "--no-plot"]) == 2  # usage
    err = capsys.readouterr().err
    assert err.startswith("wheelleg run: unknown plant override 'mass'; known: body_mass_scale")
    assert err.count("\n") == 1
