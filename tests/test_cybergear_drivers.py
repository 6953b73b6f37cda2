"""Two published CyberGear drivers from PyPI against ``wheelleg emulate`` in another process.

The transport is python-can's ``udp_multicast`` (a real python-can bus between
processes, on loopback; needs msgpack). ``python-cybergear`` (grrodre, host
0xFD) opens its own python-can bus; ``CyberGearDriver`` (host 0x00) is given a
send function and fed the received frames, as its README shows. Every
command of each driver's API is sent; the drivers' own read-backs must agree
with what was commanded.
"""
from __future__ import annotations

import os
import random
import subprocess
import sys
import time

import pytest

from drivers_helpers import eventually

can = pytest.importorskip("can")
pytest.importorskip("msgpack", reason="python-can's udp_multicast needs msgpack (pip install '.[drivers]')")
cybergear = pytest.importorskip("cybergear", reason="python-cybergear is not installed (pip install '.[drivers]')")
CyberGearDriver = pytest.importorskip("CyberGearDriver", reason="CyberGearDriver is not installed (pip install '.[drivers]')")

UID = 0x1122_3344_5566_7788
pytestmark = [pytest.mark.timeout(120), pytest.mark.slow]


@pytest.fixture
def emulator():
    """``wheelleg emulate cybergear`` in its own process on a fresh multicast group; yields the bus kwargs."""
    rng = random.Random(os.getpid() ^ time.monotonic_ns())
    bus = {"interface": "udp_multicast", "channel": f"239.255.{rng.randrange(1, 255)}.{rng.randrange(1, 255)}",
           "port": rng.randrange(20000, 60000)}
    def start(*ids: int, uid: int | None = None):
        args = [sys.executable, "-m", "wheelleg.hil.cli", "emulate", "cybergear", "--host", "0",
                "-i", "udp_multicast", "-c", bus["channel"], "--bus-kwargs", f"port={bus['port']}"]
        args += [a for i in ids for a in ("--id", str(i))] + (["--uid", hex(uid)] if uid is not None else [])
        proc = subprocess.Popen(args, stderr=subprocess.PIPE, text=True)
        line = proc.stderr.readline()
        assert "Ctrl-C stops" in line, line + proc.stderr.read()
        procs.append(proc)
        return bus
    procs: list = []
    yield start
    for proc in procs:
        proc.terminate()
        proc.wait(timeout=10)


def test_python_cybergear_drives_every_command(emulator, capsys):
    from cybergear import CyberGearMotor
    from cybergear.exceptions import CybergearMotorInitException

    bus = emulator(1, uid=UID)
    motor = CyberGearMotor(bus_config=bus, can_id=1, poll_interval=0.05)
    try:
        assert motor.device_id == UID.to_bytes(8, "little").hex()

        def near(name, target, tol):
            return eventually(lambda: getattr(motor, name) is not None and abs(getattr(motor, name) - target) < tol,
                              8.0, f"{name} -> {target}")

        def mode(name):
            motor.disable()
            motor.run_mode = name
            motor.enable()
            eventually(lambda: motor.run_mode == name, what=f"run_mode {name}")

        mode("operation")  # motion control: MIT law to 0.5 rad
        motor.motor_control(torque=0.0, position=0.5, velocity=0.0, kp=20.0, kd=1.0)
        near("mech_pos", 0.5, 0.05)
        mode("current")
        motor.iq_ref = 0.5
        near("iq_ref", 0.5, 1e-6)
        eventually(lambda: motor.mech_vel > 1.0, what="current mode turns the shaft")
        mode("speed")
        motor.spd_ref = 3.0
        near("spd_ref", 3.0, 1e-6)
        near("mech_vel", 3.0, 0.3)
        mode("position")
        motor.limit_spd = 5.0
        motor.loc_ref = 2.0
        near("loc_ref", 2.0, 1e-6)
        near("limit_spd", 5.0, 1e-6)
        near("mech_pos", 2.0, 0.05)
        motor.quick_move(4.0)
        eventually(lambda: motor.run_mode == "quick_move", what="quick move")
        near("mech_vel", 4.0, 0.4)
        motor.quick_stop()
        near("mech_vel", 0.0, 0.2)
        motor.disable()
        motor.return_zero_position()  # run_mode 4 then enable: back to 0 rad at limit_spd
        eventually(lambda: motor.run_mode == "zero_position", what="zero return")
        near("mech_pos", 0.0, 0.05)
        mode("speed")
        motor.spd_ref = 5.0
        near("mech_vel", 5.0, 0.5)
        motor.emergency_brake()
        eventually(lambda: motor.feedback.mode == 3, what="brake mode in the feedback")
        near("mech_vel", 0.0, 0.1)
        motor.disable()
        assert motor.encoder_calibration(timeout=10.0) == pytest.approx(0.4537, abs=1e-6)
        motor.reset_zero_position()
        near("mech_pos", 0.0, 1e-3)
        motor.stop_polling()
        capsys.readouterr()
        motor.fetch_parameter_table()
        # the table's 84 entries arrive as a burst of frames: wait for them, not a second
        eventually(lambda: len(motor._parameters_table) >= 84, what="the parameter table")
        motor.print_parameter_table()
        table = dict(line.split(": ", 1) for line in capsys.readouterr().out.splitlines())
        assert table["app_code_name"] == "dog_motor" and table["can_id"] == "1"
        assert float(table["gear_ratio"]) == pytest.approx(7.75) and table["over_temp_time"] == "20000"
        assert len(table) == 84  # every entry of the manual's table
        motor.set_can_id(3)
    finally:
        motor.close()
    moved = CyberGearMotor(bus_config=bus, can_id=3, poll_interval=None)
    try:
        assert moved.device_id == UID.to_bytes(8, "little").hex()
    finally:
        moved.close()
    with pytest.raises(CybergearMotorInitException):
        CyberGearMotor(bus_config=bus, can_id=1, poll_interval=None).close()


def test_cybergeardriver_drives_every_command(emulator):
    from CyberGearDriver import CyberGearMotor, RunMode

    bus_kwargs = emulator(2)
    bus = can.Bus(**bus_kwargs)
    motor = CyberGearMotor(2, send_message=lambda m: bus.send(
        can.Message(arbitration_id=m.arbitration_id, data=m.data, is_extended_id=True)))
    # timeout: how long its thread's recv waits before it sees a stop (python-can's default 1 s was
    # the test's last second: nothing arrives once the motor is left alone)
    notifier = can.Notifier(bus, [motor.message_received], timeout=0.05)
    try:
        def param(name, target, tol):
            def check():
                motor.request_parameter(name)
                return name in motor.params and abs(motor.params[name] - target) < tol
            eventually(check, 8.0, f"{name} -> {target}")

        def state(name, target, tol):
            def check():
                motor.request_motor_state()
                return name in motor.state and abs(motor.state[name] - target) < tol
            eventually(check, 8.0, f"state {name} -> {target}")

        def mode(run_mode):
            motor.stop()
            motor.mode(run_mode)
            motor.enable()
            param("run_mode", run_mode.value, 0.5)

        mode(RunMode.OPERATION_CONTROL)
        motor.control(position=0.5, velocity=0.0, torque=0.0, kp=20.0, kd=1.0)
        state("position", 0.5, 0.05)
        # (its mode_status and id fault flags read bytes of a 16-bit field as if they were bits: always 0)
        mode(RunMode.TORQUE)
        motor.set_parameter("iq_ref", 0.5)
        param("iq_ref", 0.5, 1e-6)
        mode(RunMode.VELOCITY)
        motor.set_parameter("spd_ref", 3.0)
        param("spd_ref", 3.0, 1e-6)
        state("velocity", 3.0, 0.3)
        mode(RunMode.POSITION)
        motor.set_parameter("loc_ref", 1.0)
        param("loc_ref", 1.0, 1e-6)
        state("position", 1.0, 0.05)
        motor.stop()  # else the position loop drives to loc_ref again from the new zero
        state("velocity", 0.0, 0.01)  # at rest first: a shaft still coasting leaves the new zero
        motor.set_zero_position()
        state("position", 0.0, 0.01)
        param("VBUS", 24.0, 1e-3)
        motor.set_parameter("limit_spd", 10.0)  # the stored table 0x2018 (type 8), read back by type 9
        param("limit_spd", 10.0, 1e-6)
        param("GearRatio", 7.75, 1e-6)
        param("CAN_ID", 2, 0.5)
        motor.request_motor_fault_status()
        eventually(lambda: motor.faults.get("Over temperature") is False, what="fault word")
        motor.stop()
        motor.change_motor_id(4)
        param("CAN_ID", 4, 0.5)  # the driver now addresses id 4, and the motor answers from it
    finally:
        notifier.stop()
        bus.shutdown()
