"""The quadruped's plant (emulators/quadruped/plant.py): its devices on the contract's buses, bound to MuJoCo.

A driver on two virtual buses talks to the plant frame by frame: each CyberGear
answers on its own bus only, an MIT command moves its own joint the commanded
way, the IMU and the remote (QuadOperator every 20 ms) talk on bus 0 only.
"""
from __future__ import annotations

import uuid

import can
import numpy as np
import pytest

from wheelleg.dbc import CAN1, CAN2, load_bus
from wheelleg.dbc import cybergear as cg
from wheelleg.emulators.quadruped import description as D
from wheelleg.emulators.quadruped.physics import QuadrupedPhysics
from wheelleg.emulators.quadruped.plant import QuadrupedPlant

HOST = 0xFD
DB = load_bus(CAN2, robot="quadruped")
MOTION = DB.get_message_by_name("CG_MotionCmd")


@pytest.fixture
def rig():
    """(plant, driver buses role -> bus) on fresh virtual channels, the robot held in the air."""
    names = {role: f"quad-{role}-{uuid.uuid4().hex}" for role in (CAN1, CAN2)}
    plant_side = {role: can.Bus(interface="virtual", channel=ch) for role, ch in names.items()}
    driver = {role: can.Bus(interface="virtual", channel=ch) for role, ch in names.items()}
    physics = QuadrupedPhysics()
    physics.reset_standing(0.25)
    physics.model.opt.gravity[:] = 0.0  # hung in the air: only the motors move the legs
    physics.data.qpos[2] += 0.2
    plant = QuadrupedPlant(physics, plant_side, np.random.default_rng(0))
    yield plant, driver
    for bus in (*plant_side.values(), *driver.values()):
        bus.shutdown()


def _run(plant: QuadrupedPlant, steps: int, t0_s: float = 0.0) -> float:
    for k in range(steps):
        now = t0_s + k * 0.001
        plant.step(now)
        for node in plant.nodes.values():
            node.service(now + 0.001)
    return t0_s + steps * 0.001


def _drain(bus: can.BusABC) -> list[can.Message]:
    out = []
    while (msg := bus.recv(timeout=0)) is not None:
        out.append(msg)
    return out


def _enable_and_command(bus: can.BusABC, motor: int, p_ref: float, kp: float, kd: float) -> None:
    bus.send(can.Message(arbitration_id=cg.request_id(cg.T_ENABLE, HOST, motor), data=bytes(8), is_extended_id=True))
    data = MOTION.encode({"PosRef": p_ref, "VelRef": 0.0, "Kp": kp, "Kd": kd})
    bus.send(can.Message(arbitration_id=cg.motion_id(0.0, motor), data=data, is_extended_id=True))


@pytest.mark.parametrize("name", ["FR_thigh", "FL_abduction", "RR_calf", "RL_thigh"])
def test_an_mit_command_moves_its_own_joint_and_only_its_bus_answers(rig, name):
    plant, driver = rig
    motor = next(m for m in D.JOINT_MOTORS if m.name == name)
    own, other = (CAN1, CAN2) if motor.bus == 0 else (CAN2, CAN1)
    start = plant.physics.shaft_state(name)[0]
    goal = float(np.clip(start + 0.3, *motor.range_rad))
    _drain(driver[own]), _drain(driver[other])
    _enable_and_command(driver[own], motor.motor_id, goal, kp=20.0, kd=0.5)
    _run(plant, 300)
    assert plant.physics.shaft_state(name)[0] == pytest.approx(goal, abs=0.02)
    for m in D.JOINT_MOTORS:
        if m.name != name:
            assert plant.physics.shaft_state(m.name)[1] == pytest.approx(0.0, abs=0.5)  # the others stay limp
    replies = [cg.reply_motor(f.arbitration_id) for f in _drain(driver[own]) if f.is_extended_id]
    assert replies == [motor.motor_id, motor.motor_id]  # enable and motion each answered once
    assert not any(f.is_extended_id for f in _drain(driver[other]))
    # a command sent on the other bus reaches nobody
    _enable_and_command(driver[other], motor.motor_id, start, kp=20.0, kd=0.5)
    _run(plant, 50, 0.3)
    assert not any(f.is_extended_id for f in _drain(driver[other]))


def test_imu_and_remote_talk_on_bus_0_only(rig):
    plant, driver = rig
    plant.remote.set(Mode=2, VelX=0.5, Height=0.22)
    _run(plant, 100)
    frames = _drain(driver[CAN1])
    db = load_bus(CAN1, robot="quadruped")
    names = [db.get_message_by_frame_id(f.arbitration_id).name for f in frames]
    # 0.1 s of simulated time served every 1 ms (the virtual bus stamps wall time: count, not stamps)
    assert names.count("IMU_Orientation") == names.count("IMU_Gyro") == names.count("IMU_Accel") == 51  # and every 2 ms
    remote = [f for f in frames if f.arbitration_id == 0x301]
    assert len(remote) == 6  # the first at once, then every 20 ms up to 0.1 s
    decoded = db.decode_message(0x301, remote[-1].data, decode_choices=False)
    assert (decoded["Mode"], decoded["VelX"], decoded["Height"]) == (2, pytest.approx(0.5), pytest.approx(0.22))
    assert _drain(driver[CAN2]) == []
    with pytest.raises(ValueError, match="not QuadOperator signals"):
        plant.remote.set(LegLength=0.2)
