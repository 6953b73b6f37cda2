"""Published RobStride drivers against ``wheelleg emulate robstride`` in another process (udp_multicast).

``robstride`` (PyPI 0.1.0) takes a python-can bus: it is given one on the
test's multicast group. ``robstride-dynamics`` (0.0.1) opens SocketCAN in
``connect()``; its bus handle is set to the test's bus instead, and the rest
of its API is used unchanged. Their read-backs must agree with what was
commanded. Fault reports are checked in-process (a fault cannot be caused
from the bus alone): the drivers' own parsers read the emulator's frames.
"""
from __future__ import annotations

import math
import time

import pytest

from drivers_helpers import Emulators, emulators, eventually  # noqa: F401 (emulators: a fixture)
from wheelleg.emulators.robstride import RobStride

can = pytest.importorskip("can")
pytest.importorskip("msgpack", reason="python-can's udp_multicast needs msgpack (pip install '.[drivers]')")

pytestmark = [pytest.mark.timeout(180)]


@pytest.mark.slow
@pytest.mark.parametrize("model, driver_model", [("RS01", 1), ("RS04", 4)])
def test_robstride_client_drives_run_modes_parameters_id_change_and_stop(emulators, model, driver_model):
    client_mod = pytest.importorskip("robstride.client", reason="robstride is not installed (pip install '.[drivers]')")
    emulators.start("robstride", "--id", "1", "--model", model)
    bus = emulators.driver_bus()
    client = client_mod.Client(bus, recv_timeout=3)
    RunMode = client_mod.RunMode
    try:
        def mode(run_mode):
            client.disable(1, driver_model)
            client.write_param(1, "run_mode", run_mode, driver_model)
            assert client.read_param(1, "run_mode") == run_mode
            return client.enable(1, driver_model)

        def param_near(name, target, tol, what):
            eventually(lambda: abs(client.read_param(1, name) - target) < tol, 8.0, what)

        fb = mode(RunMode.Speed)
        assert fb.servo_id == 1 and fb.errors == [] and fb.temp == pytest.approx(25.0, abs=0.1)
        client.write_param(1, "spd_ref", 3.0, driver_model)
        assert client.read_param(1, "spd_ref") == pytest.approx(3.0)
        param_near("mechvel", 3.0, 0.3, "speed mode")
        fb = client.write_param(1, "spd_ref", 3.0, driver_model)  # its feedback decodes with the model's scales
        assert fb.velocity == pytest.approx(3.0, abs=0.3)
        mode(RunMode.Current)
        client.write_param(1, "iq_ref", 1.0, driver_model)
        param_near("iqf", 1.0, 0.05, "current mode")
        mode(RunMode.Position)  # profile position: speed limit vel_max (0x7024, not in the driver's names)
        client.write_param(1, 0x7024, 5.0, driver_model)
        client.write_param(1, "loc_ref", 1.0, driver_model)
        param_near("mechpos", 1.0, 0.05, "position mode")
        fb = client.write_param(1, "limit_torque", 5.0, driver_model)
        assert fb.angle == pytest.approx(1.0, abs=0.05)
        assert client.read_param(1, "limit_torque") == pytest.approx(5.0)
        assert client.read_param(1, "vbus") == pytest.approx(48.0)
        fb = client.disable(1, driver_model)
        assert fb.mode == client_mod.MotorMode.Reset
        client.update_id(1, 2)
        fb = client.enable(2, driver_model)
        assert fb.servo_id == 2
        client.disable(2, driver_model)
    finally:
        bus.shutdown()


class _IntIds:
    """The bus as SocketCAN takes a frame: robstride-dynamics builds MIT ids from numpy integers, which
    SocketCAN's struct packing converts and python-can's multicast transport (msgpack) cannot."""

    def __init__(self, bus):
        self.bus = bus

    def send(self, msg, timeout=None):
        msg.arbitration_id = int(msg.arbitration_id)
        self.bus.send(msg, timeout)

    def recv(self, timeout=None):
        return self.bus.recv(timeout)

    def shutdown(self):
        self.bus.shutdown()


@pytest.mark.slow
def test_robstride_dynamics_drives_mit_speed_parameters_and_ping(emulators):
    rd = pytest.importorskip("robstride_dynamics", reason="robstride-dynamics is not installed (pip install '.[drivers]')")
    from robstride_dynamics.bus import Motor, RobstrideBus
    from robstride_dynamics.protocol import ParameterType as PT
    emulators.start("robstride", "--id", "3", "--model", "RS03", "--uid", "0x1122334455667788")
    rbus = RobstrideBus("unused", {"knee": Motor(id=3, model="rs-03")})
    rbus.channel_handler = _IntIds(emulators.driver_bus())  # connect() opens SocketCAN only
    try:
        device_id, uuid = rbus.ping_by_id(3, timeout=3.0)
        assert device_id == 3 and bytes(uuid) == (0x1122334455667788).to_bytes(8, "little")
        rbus.write("knee", PT.MODE, 0)  # MIT
        assert rbus.read("knee", PT.MODE) == 0
        rbus.enable("knee")

        def mit_at(target):
            rbus.write_operation_frame("knee", position=target, kp=40.0, kd=2.0)
            pos, vel, torque, temp = rbus.read_operation_frame("knee")
            return abs(pos - target) < 0.05 and abs(vel) < 0.2

        eventually(lambda: mit_at(-1.0), 8.0, "MIT to -1 rad")
        rbus.write_operation_frame("knee", position=0.0, kp=0.0, kd=0.0, torque=2.0)
        _, _, torque, _ = rbus.read_operation_frame("knee")
        assert torque == pytest.approx(2.0, abs=0.05)
        rbus.disable("knee")
        rbus.write("knee", PT.MODE, 2)  # speed
        rbus.enable("knee")
        rbus.write("knee", PT.VELOCITY_TARGET, -4.0)
        assert rbus.read("knee", PT.VELOCITY_TARGET) == pytest.approx(-4.0)
        eventually(lambda: abs(rbus.read("knee", PT.MECHANICAL_VELOCITY) + 4.0) < 0.3, 8.0, "speed -4 rad/s")
        rbus.write("knee", PT.CAN_TIMEOUT, 20000)  # uint32 parameter
        assert rbus.read("knee", PT.CAN_TIMEOUT) == 20000
        rbus.write("knee", PT.EPSCAN_TIME, 3)  # uint16 parameter
        assert rbus.read("knee", PT.EPSCAN_TIME) == 3
        assert rbus.read("knee", PT.VBUS) == pytest.approx(48.0)
        time.sleep(1.2)  # canTimeout 1 s without a frame: the motor drops to reset mode (offline behaviour)
        rbus.write("knee", PT.CAN_TIMEOUT, 0)
        assert abs(rbus.read("knee", PT.MECHANICAL_VELOCITY)) < abs(-4.0) - 0.5  # no longer driven
        rbus.disable("knee")
    finally:
        rbus.channel_handler.shutdown()
        rbus.channel_handler = None
    assert rd is not None


# -- in process: fault reports read by the drivers' parsers ---------------------------------------
def _request(ctype: int, motor: int, host: int = 0xAA, data: bytes = bytes(8)) -> "can.Message":
    return can.Message(arbitration_id=(ctype << 24) | (host << 8) | motor, data=data, is_extended_id=True)


def test_fault_bits_read_by_the_drivers_parsers():
    client_mod = pytest.importorskip("robstride.client")
    motor = RobStride("RS01", motor_id=5)
    client = client_mod.Client(bus=None)
    motor.inject_fault("FaultOverTemp")
    (reply,) = motor.handle(_request(3, 5), 0.0)
    fb = client._parse_feedback_resp(reply, 5, 1)
    assert fb.errors == [client_mod.MotorError.Overtemp] and fb.mode == client_mod.MotorMode.Reset
    (words,) = motor.handle(_request(21, 5), 0.0)
    assert words.arbitration_id >> 24 == 21 and words.data[0] & 1  # fault word bit 0: over-temperature
    motor.handle(_request(4, 5, data=bytes([1]) + bytes(7)), 0.0)  # stop with ClearFault
    (reply,) = motor.handle(_request(3, 5), 0.0)
    assert client._parse_feedback_resp(reply, 5, 1).errors == []


def test_each_models_mit_scales_match_robstride_dynamics_tables():
    from robstride_dynamics import table as T
    for model in ("RS01", "RS02", "RS03", "RS04"):
        m = RobStride(model, motor_id=1)
        key = "rs-0" + model[-1]
        fb = m._lay.feedback.signals
        cmd = m._lay.motion.signals
        assert fb["Pos"].maximum == pytest.approx(T.MODEL_MIT_POSITION_TABLE[key]) == pytest.approx(4 * math.pi)
        assert fb["Vel"].maximum == T.MODEL_MIT_VELOCITY_TABLE[key] and fb["Torque"].maximum == T.MODEL_MIT_TORQUE_TABLE[key]
        assert cmd["Kp"].maximum == T.MODEL_MIT_KP_TABLE[key] and cmd["Kd"].maximum == T.MODEL_MIT_KD_TABLE[key]
        assert m.LINE.torque_limit_nm == T.MODEL_MIT_TORQUE_TABLE[key]
