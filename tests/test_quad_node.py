"""The quadruped's controller on its buses: the start sequence, MIT frames per motor on its
bus, passive damping, the E-stop within a remote period, the offline watch (passive within
20 ms), bad frames counted, and the lockstep node the rig drives (SYNC in, heartbeats out)."""
from __future__ import annotations

import math

import can
import numpy as np
import pytest

from wheelleg.controller.quadruped import constants as C
from wheelleg.controller.quadruped import params as P
from wheelleg.controller.quadruped.getup import fold_pose
from wheelleg.controller.quadruped.modes import Mode
from wheelleg.controller.quadruped.node import QuadController, QuadrupedNode, heartbeat_mask
from wheelleg.dbc import CAN1, CAN2, load_bus
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import truncating_raw

DB = {CAN1: load_bus(CAN1, robot="quadruped"), CAN2: load_bus(CAN2, robot="quadruped")}
FEEDBACK = DB[CAN2].get_message_by_name("CG_Feedback")
MOTION = DB[CAN2].get_message_by_name("CG_MotionCmd")
HEARTBEAT = DB[CAN1].get_message_by_name("Heartbeat")
DT = P.CONTROL_PERIOD
REMOTE_PERIOD = 0.02  # s, the rig's remote sends every 20 ms


def _std(name: str, **signals) -> can.Message:
    msg = DB[CAN1].get_message_by_name(name)
    return can.Message(arbitration_id=msg.frame_id, data=msg.encode(signals, strict=False), is_extended_id=False)


def _bus_of(motor: int) -> str:
    return CAN1 if motor <= 6 else CAN2


class FakeQuadruped:
    """Motors that reach what they are told, a level IMU and a remote: QuadController fed tick by tick."""

    def __init__(self, q=None):
        self.ctl = QuadController()
        self.q = {m: 0.0 for m in C.MOTOR_IDS}
        for leg in range(4):
            for j in range(3):
                self.q[C.motor_id(leg, j)] = float((fold_pose() if q is None else q)[leg, j])
        self.silent: set = set()
        self.remote = {"Mode": 0, "EStop": 0, "VelX": 0.0, "VelY": 0.0, "YawRate": 0.0, "Height": P.HEIGHT_NOMINAL,
                       "Roll": 0.0, "Pitch": 0.0, "Yaw": 0.0}
        self.tick_no = 0
        self.result = None
        self.sent: list = []

    def feedback(self, motor: int) -> can.Message:
        raw = {s.name: truncating_raw(s, 0.0) for s in FEEDBACK.signals}
        raw["Pos"] = truncating_raw(FEEDBACK.get_signal_by_name("Pos"), self.q[motor])
        raw["Temp"] = 300
        return can.Message(arbitration_id=cg.reply_id(cg.T_FEEDBACK, motor, C.CG_HOST_ID, 2),
                           data=FEEDBACK.encode(raw, scaling=False), is_extended_id=True)

    def frames(self):
        now = self.tick_no * DT
        out = [(_bus_of(m), self.feedback(m)) for m in C.MOTOR_IDS if m not in self.silent]
        out += [(CAN1, _std("IMU_Orientation", QuatW=1.0, QuatX=0.0, QuatY=0.0, QuatZ=0.0)),
                (CAN1, _std("IMU_Gyro", RateX=0.001 * (self.tick_no % 2), RateY=0.0, RateZ=0.0)),
                (CAN1, _std("IMU_Accel", AccX=0.0, AccY=0.0, AccZ=9.81))]
        if round(now / DT) % round(REMOTE_PERIOD / DT) == 0:
            out.append((CAN1, _std("QuadOperator", **self.remote)))
        return out

    def step(self, extra=()):
        now = self.tick_no * DT
        for bus, msg in [*self.frames(), *extra]:
            self.ctl.on_frame(msg, bus, now)
        self.result = self.ctl.tick(self.tick_no, now)
        for bus, frames in self.result.frames.items():
            for msg in frames:
                self.sent.append((self.tick_no, bus, msg))
                if msg.is_extended_id and cg.comm_type(msg.arbitration_id) == cg.T_MOTION:
                    self.q[cg.target(msg.arbitration_id)] = MOTION.decode(msg.data)["PosRef"]
        self.tick_no += 1
        return self.result

    def run(self, seconds: float):
        for _ in range(round(seconds / DT)):
            self.step()
        return self.result

    def heartbeat(self) -> dict:
        return HEARTBEAT.decode(self.result.frames[CAN1][-1].data, decode_choices=False)

    def motion_frames(self):
        return [(bus, msg) for bus, frames in self.result.frames.items() for msg in frames
                if msg.is_extended_id and cg.comm_type(msg.arbitration_id) == cg.T_MOTION]


def test_the_first_tick_starts_every_motor_on_its_bus():
    robot = FakeQuadruped()
    robot.step()
    for bus in (CAN1, CAN2):
        ext = [m for m in robot.result.frames[bus] if m.is_extended_id]
        kinds = [(cg.comm_type(m.arbitration_id), cg.target(m.arbitration_id)) for m in ext]
        motors = [m for m in C.MOTOR_IDS if _bus_of(m) == bus]
        assert kinds == [(t, m) for m in motors for t in (cg.T_STOP, cg.T_PARAM_WRITE, cg.T_ENABLE)]
        assert robot.result.frames[bus][-1].arbitration_id == HEARTBEAT.frame_id


def test_passive_damps_every_joint_and_holds_no_position():
    robot = FakeQuadruped()
    robot.run(0.1)
    assert robot.ctl.mode == Mode.PASSIVE
    frames = robot.motion_frames()
    assert sorted(cg.target(m.arbitration_id) for _, m in frames) == list(C.MOTOR_IDS)
    for bus, msg in frames:
        assert bus == _bus_of(cg.target(msg.arbitration_id))
        fields = MOTION.decode(msg.data)
        assert fields["Kp"] == 0.0 and fields["Kd"] == pytest.approx(P.PASSIVE_KD, abs=1e-3)
        assert cg.motion_torque(msg.arbitration_id) == pytest.approx(0.0, abs=1e-3)


def test_stand_up_from_lying_folded_reaches_the_stand():
    robot = FakeQuadruped()
    robot.run(0.1)
    robot.remote["Mode"] = int(Mode.STAND_UP)
    robot.run(0.05)
    assert robot.heartbeat()["Mode"] == Mode.STAND_UP and robot.heartbeat()["MotorsEnabled"] == 1
    robot.run(2.2)
    assert robot.ctl.getup.done
    for _, msg in robot.motion_frames():
        assert MOTION.decode(msg.data)["Kp"] == pytest.approx(P.GETUP_KP, abs=0.01)
    height = robot.result.debug["height"]
    assert height == pytest.approx(P.HEIGHT_NOMINAL, abs=0.002)
    robot.remote["Mode"] = int(Mode.BALANCE_STAND)
    robot.run(0.1)
    assert robot.ctl.mode == Mode.BALANCE_STAND


@pytest.mark.parametrize("mode", [Mode.STAND_UP, Mode.BALANCE_STAND, Mode.LOCOMOTION])
def test_the_estop_makes_it_passive_within_one_remote_period(mode):
    robot = FakeQuadruped()
    robot.remote["Mode"] = int(Mode.STAND_UP)
    robot.run(2.3)
    robot.remote["Mode"] = int(mode)
    robot.run(0.3)
    assert robot.ctl.mode == mode
    robot.remote["EStop"] = 1
    pressed = robot.tick_no
    while robot.ctl.mode != Mode.PASSIVE:
        robot.step()
    assert (robot.tick_no - pressed) * DT <= REMOTE_PERIOD + DT
    assert all(MOTION.decode(m.data)["Kp"] == 0.0 for _, m in robot.motion_frames())
    assert robot.heartbeat()["FaultLatched"] == 1
    # released with the switch still on: stays passive until the remote asks for passive
    robot.remote["EStop"] = 0
    robot.run(0.2)
    assert robot.ctl.mode == Mode.PASSIVE
    robot.remote["Mode"] = 0
    robot.run(0.05)
    robot.remote["Mode"] = int(Mode.STAND_UP)
    robot.run(0.05)
    assert robot.ctl.mode == Mode.STAND_UP


@pytest.mark.parametrize("motor", [1, 8, 12])
def test_a_silent_motor_makes_it_passive_within_20_ms(motor):
    robot = FakeQuadruped()
    robot.remote["Mode"] = int(Mode.STAND_UP)
    robot.run(2.3)
    robot.silent.add(motor)
    last_heard = robot.tick_no - 1
    while robot.ctl.mode != Mode.PASSIVE:
        robot.step()
        assert robot.tick_no - last_heard < 10
    assert (robot.tick_no - 1 - last_heard) * DT == pytest.approx(0.020)
    leg = (motor - 1) // 3
    assert robot.heartbeat()["OfflineMask"] == 1 << leg and robot.heartbeat()["MotorsEnabled"] == 0
    # the damping goes to every motor, the silent one too
    assert sorted(cg.target(m.arbitration_id) for _, m in robot.motion_frames()) == list(C.MOTOR_IDS)


def test_feedback_on_the_wrong_bus_does_not_count():
    robot = FakeQuadruped()
    robot.silent.add(2)
    robot.run(0.1)
    robot.remote["Mode"] = int(Mode.STAND_UP)
    wrong = (CAN2, robot.feedback(2))
    for _ in range(10):
        robot.step(extra=[wrong])
    assert robot.ctl.mode == Mode.PASSIVE and robot.heartbeat()["OfflineMask"] == 0b1


def test_bad_frames_are_counted_and_change_nothing():
    robot = FakeQuadruped()
    robot.remote["Mode"] = int(Mode.STAND_UP)
    robot.run(0.5)
    bad_remote = can.Message(arbitration_id=0x301, data=b"\x01\x02", is_extended_id=False)  # DLC 2
    out_of_range = can.Message(arbitration_id=0x301, data=bytes([7, 0, 0, 0, 0, 0, 0, 0]), is_extended_id=False)
    robot.step(extra=[(CAN1, bad_remote), (CAN1, out_of_range), (CAN2, bad_remote)])
    assert robot.heartbeat()["BadFrames"] == 2  # on bus 1 a QuadOperator is not even looked at
    assert robot.ctl.mode == Mode.STAND_UP and robot.ctl.bus.operator.mode == Mode.STAND_UP


def test_heartbeat_mask_packs_legs_imu_and_remote():
    assert heartbeat_mask(0) == 0
    assert heartbeat_mask(1 << 4) == 0b10  # FL thigh -> leg 1
    assert heartbeat_mask((1 << 11) | (1 << 12) | (1 << 13)) == 0b111000


@pytest.mark.slow
def _drain(bus: can.BusABC) -> list[can.Message]:
    """Every frame waiting on ``bus`` (the virtual bus delivers on send: what a tick sent is
    there; the first wait only in case it is late). Twenty 0.1 s waits a bus took 5 s."""
    got, msg = [], bus.recv(0.1)
    while msg is not None:
        got.append(msg)
        msg = bus.recv(0.0)
    return got


def test_the_lockstep_node_ticks_on_sync_from_both_buses():
    """What the rig does: SYNC k on both buses, ``service()``, the heartbeats of tick k on both."""
    names = ("q-bus0", "q-bus1")
    rig = [can.Bus(interface="virtual", channel=n) for n in names]
    ctl = [can.Bus(interface="virtual", channel=n) for n in names]
    node = QuadrupedNode(ctl[0], ctl[1], sync=True)
    sync = DB[CAN1].get_message_by_name("SYNC")
    try:
        for tick in range(3):
            rig[0].send(can.Message(arbitration_id=sync.frame_id, data=sync.encode({"Tick": tick}),
                                    is_extended_id=False))
            assert not node.service()  # one SYNC is not enough
            rig[1].send(can.Message(arbitration_id=sync.frame_id, data=sync.encode({"Tick": tick}),
                                    is_extended_id=False))
            assert node.service()
            for bus in rig:
                got = _drain(bus)
                beats = [HEARTBEAT.decode(m.data)["Tick"] for m in got if m.arbitration_id == HEARTBEAT.frame_id]
                assert beats == [tick]
        assert node.ticks == 3 and math.isclose(node.now(), 2 * DT)
        assert set(node.last_result.debug) >= {"mode", "roll", "height"}
        node.disable()
        stops = [bus.recv(0.1) for bus in rig]
        assert all(m is not None and cg.comm_type(m.arbitration_id) == cg.T_STOP for m in stops)
    finally:
        for bus in rig + ctl:
            bus.shutdown()


def test_commands_that_are_not_numbers_become_passive_damping(monkeypatch):
    """A fault of the controller's own (NaN out of a law) never reaches a motor: it damps them."""
    robot = FakeQuadruped()
    robot.remote["Mode"] = int(Mode.STAND_UP)
    robot.run(0.5)
    real = robot.ctl.getup.step

    def broken(sensed):
        commands = real(sensed)
        commands.q[2, 1] = float("nan")
        return commands

    monkeypatch.setattr(robot.ctl.getup, "step", broken)
    robot.step()
    assert robot.ctl.mode == Mode.STAND_UP
    for _, msg in robot.motion_frames():
        fields = MOTION.decode(msg.data)
        assert fields["Kp"] == 0.0 and fields["Kd"] == pytest.approx(P.PASSIVE_KD, abs=1e-3)
