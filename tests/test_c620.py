"""C620 + M3508 emulator conformance: current frames in, 1 kHz feedback out, over a virtual bus."""
from __future__ import annotations

import math
import threading
import time
import uuid

import can
import pytest

from wheelleg.controller import constants as C
from wheelleg.dbc import load_file
from wheelleg.emulators.c620 import C620
from wheelleg.emulators.node import DeviceNode
from wheelleg.hil.cli import build_parser
from wheelleg.hil.commands import emulate

DB = load_file("c620.dbc")
CMD_1_4, CMD_5_8 = DB.get_message_by_name("C620_Cmd_1_4"), DB.get_message_by_name("C620_Cmd_5_8")
RPM_PER_RAD_S = 60.0 / (2 * math.pi)


class EscDriver:
    """Host side: sends current frames from the DBC, collects and decodes feedback."""

    def __init__(self, bus: can.BusABC, node: DeviceNode):
        self.bus, self.node, self.t = bus, node, 0.0

    def currents(self, amps: dict[int, float], frame=CMD_1_4, **kw) -> None:
        first = 1 if frame is CMD_1_4 else 5
        values = {f"ESC{i}_Current": amps.get(i, 0.0) for i in range(first, first + 4)}
        self.send(frame.frame_id, frame.encode(values), **kw)

    def send(self, can_id: int, data: bytes, extended: bool = False, **kw) -> None:
        self.bus.send(can.Message(arbitration_id=can_id, data=data, is_extended_id=extended, **kw))
        assert self.node.service(self.t) == 1  # feedback due now stays queued for drain()

    def drain(self) -> list[can.Message]:
        out = []
        while (msg := self.bus.recv(timeout=0)) is not None:
            out.append(msg)
        return out

    def run(self, escs: list[C620], seconds: float, dt: float = 0.001) -> list[can.Message]:
        """Shafts alone for ``seconds``, the node served every ``dt``; the frames the host got."""
        got = []
        for _ in range(round(seconds / dt)):
            for esc in escs:
                esc.step_alone(dt, self.t + dt)
            self.t += dt
            self.node.service(self.t)
            got += self.drain()
        return got


def decode(msg: can.Message) -> dict:
    return DB.decode_message(msg.arbitration_id, msg.data)


@pytest.fixture
def rig(vbus_pair):
    esc = C620(esc_id=1)
    return EscDriver(vbus_pair[0], DeviceNode(vbus_pair[1], [esc])), esc


def test_feedback_every_millisecond_of_simulated_time(rig):
    drv, _ = rig
    frames = drv.run([rig[1]], 0.010)
    assert [m.arbitration_id for m in frames] == [0x201] * 10
    assert all(m.dlc == 8 and not m.is_extended_id and m.data[7] == 0 for m in frames)
    drv.node.service(drv.t)  # the same instant again: nothing new is due
    assert drv.drain() == []
    sent = rig[1].periodic(drv.t + 0.001)  # what the device emits (a virtual bus restamps on receipt)
    assert len(sent) == 1 and sent[0].timestamp == drv.t + 0.001 and not sent[0].is_rx


@pytest.mark.parametrize("amps", [5.0, -5.0])
def test_current_makes_the_rotor_speed_rise_with_the_right_sign_and_scale(rig, amps):
    drv, esc = rig
    drv.currents({1: amps})
    frames = drv.run([esc], 0.020)
    shaft = esc.shaft
    accel = (amps * C.M3508_TORQUE_CONSTANT - math.copysign(shaft.coulomb, amps)) / shaft.inertia  # rad/s^2
    expected_rpm = accel * 0.020 * C.M3508_GEAR * RPM_PER_RAD_S  # rotor side, before the gearbox
    last = decode(frames[-1])
    assert last["RotorSpeed"] == pytest.approx(expected_rpm, rel=0.02)
    assert last["TorqueCurrent"] == pytest.approx(amps, abs=0.002)
    speeds = [decode(m)["RotorSpeed"] for m in frames]
    assert all(abs(b) >= abs(a) for a, b in zip(speeds, speeds[1:]))


def test_rotor_angle_is_the_output_angle_times_the_gear_ratio(rig):
    drv, esc = rig
    esc.shaft.angle = 0.25 * 2 * math.pi / C.M3508_GEAR + 1e-9  # a quarter rotor turn
    frame = esc.feedback_frame(0.0)
    assert frame.data[0:2] == (2048).to_bytes(2, "big")
    esc.shaft.angle = 7 * 2 * math.pi / C.M3508_GEAR - 1e-9  # just short of 7 rotor turns
    assert int.from_bytes(esc.feedback_frame(0.0).data[0:2], "big") == 8191
    esc.shaft.angle = -0.25 * 2 * math.pi / C.M3508_GEAR + 1e-9
    assert int.from_bytes(esc.feedback_frame(0.0).data[0:2], "big") == 6144
    assert esc.feedback_frame(0.0).data[6] == 25  # degC


def test_command_clamps_to_16384(rig):
    drv, esc = rig
    raw = bytes.fromhex("7fff800100000000")  # +32767 for ESC 1, -32767 for ESC 2
    drv.send(0x200, raw)
    assert esc.command_raw == 16384
    assert esc.output_torque(drv.t) == pytest.approx(C.WHEEL_TORQUE_LIMIT)


def test_each_esc_takes_its_own_slot_of_its_own_frame(vbus_pair):
    escs = [C620(esc_id=i) for i in (1, 2, 5, 8)]
    drv = EscDriver(vbus_pair[0], DeviceNode(vbus_pair[1], escs))
    drv.currents({1: 1.0, 2: -2.0, 3: 7.0, 4: 7.0})
    drv.currents({5: 3.0, 8: -4.0, 6: 9.0}, frame=CMD_5_8)
    assert [e.commanded_current(0.0) for e in escs] == pytest.approx([1.0, -2.0, 3.0, -4.0], abs=0.002)
    fb = drv.run(escs, 0.001)  # feedback at t = 0 (the commands' instant) and t = 1 ms
    assert sorted(m.arbitration_id for m in fb) == [0x201, 0x201, 0x202, 0x202, 0x205, 0x205, 0x208, 0x208]


def test_command_bytes_are_big_endian_int16(rig):
    drv, esc = rig
    drv.send(0x200, bytes.fromhex("c000000000000000"))  # -16384 = -20 A
    assert esc.commanded_current(0.0) == -20.0


def test_holds_the_last_command_forever_by_default(rig):
    drv, esc = rig
    drv.currents({1: 2.0})
    assert esc.commanded_current(3600.0) == pytest.approx(2.0, abs=0.002)


def test_optional_command_timeout_zeroes_the_current(vbus_pair):
    esc = C620(esc_id=1, command_timeout_s=0.05)
    drv = EscDriver(vbus_pair[0], DeviceNode(vbus_pair[1], [esc]))
    drv.currents({1: 2.0})
    frames = drv.run([esc], 0.1)
    currents = [decode(m)["TorqueCurrent"] for m in frames]
    assert currents[10] == pytest.approx(2.0, abs=0.002) and currents[-1] == 0.0
    with pytest.raises(ValueError, match="command_timeout_s"):
        C620(command_timeout_s=0.0)


def test_back_emf_stops_the_motor_below_the_no_load_speed(rig):
    drv, esc = rig
    drv.currents({1: 20.0})
    drv.run([esc], 1.0, dt=0.002)
    assert 0.95 * C.M3508_NO_LOAD_SPEED < esc.shaft.speed < C.M3508_NO_LOAD_SPEED
    esc.shaft.speed = C.M3508_NO_LOAD_SPEED + 1.0  # pushed beyond it: no drive torque, braking allowed
    assert esc.output_torque(0.0) == 0.0
    drv.currents({1: -20.0})
    assert esc.output_torque(0.0) == pytest.approx(-C.WHEEL_TORQUE_LIMIT)


def test_temperature_rises_with_current(rig):
    drv, esc = rig
    drv.currents({1: 20.0})
    esc.shaft.load_torque = -6.5  # stalled
    drv.run([esc], 30.0, dt=0.01)
    assert esc.temperature_c > 30.0
    assert decode(esc.feedback_frame(drv.t))["MotorTemp"] == round(esc.temperature_c)


def test_bad_frames_are_ignored_and_never_answered(rig):
    drv, esc = rig
    drv.currents({1: 1.0})
    good = CMD_1_4.encode({"ESC1_Current": 5.0, "ESC2_Current": 0, "ESC3_Current": 0, "ESC4_Current": 0})
    drv.send(0x200, good, extended=True)  # an extended id is another frame
    drv.send(0x200, good[:4])  # short
    drv.send(0x1FF, good)  # ESC 1 is on 0x200
    drv.send(0x200, b"", is_remote_frame=True)
    drv.send(0x201, good)  # another ESC's feedback
    assert esc.commanded_current(0.0) == pytest.approx(1.0, abs=0.002)
    assert esc.internal_errors == 0


def test_constructor_rejects_bad_ids():
    for bad in (0, 9):
        with pytest.raises(ValueError, match="1..8"):
            C620(esc_id=bad)


def test_wheelleg_emulate_c620_streams_feedback_and_takes_commands():
    channel = f"emulate-c620-{uuid.uuid4().hex}"
    args = build_parser().parse_args(["emulate", "c620", "-i", "virtual", "-c", channel, "--id", "2"])
    stop, result = threading.Event(), {}
    thread = threading.Thread(target=lambda: result.update(rc=emulate.run(args, stop)))
    host = can.Bus(interface="virtual", channel=channel)
    thread.start()
    try:
        first = host.recv(timeout=20.0)  # generous: bounds a hang only
        assert first is not None and first.arbitration_id == 0x202
        values = {f"ESC{i}_Current": 0.0 for i in range(1, 5)} | {"ESC2_Current": 3.0}
        host.send(can.Message(arbitration_id=0x200, data=CMD_1_4.encode(values), is_extended_id=False))
        deadline, current = time.monotonic() + 20.0, 0.0
        while abs(current - 3.0) > 0.01 and time.monotonic() < deadline:
            msg = host.recv(timeout=1.0)
            current = decode(msg)["TorqueCurrent"] if msg is not None else current
        assert current == pytest.approx(3.0, abs=0.01)
    finally:
        stop.set()
        thread.join(timeout=20.0)
        host.shutdown()
    assert not thread.is_alive() and result["rc"] == 0


class _RefusingBus(can.BusABC):
    """A bus whose transmit queue is always full."""

    def __init__(self):
        super().__init__(channel="refusing")

    def send(self, msg, timeout=None):
        raise can.CanOperationError("transmit buffer full")

    def _recv_internal(self, timeout):
        return None, False


def test_node_drops_and_counts_frames_the_bus_refuses():
    bus = _RefusingBus()
    node = DeviceNode(bus, [C620(esc_id=1)])
    try:
        assert node.service(0.0) == 0 and node.service(0.001) == 0
    finally:
        bus.shutdown()
    assert (node.send_errors, node.frames_out) == (2, 0)
