"""CyberGear commands beyond the basic set, and ``wheelleg emulate``'s options (docs/protocols.md)."""
from __future__ import annotations

import threading
import time
import uuid

import can
import pytest

from wheelleg.dbc import cybergear as cg
from wheelleg.emulators import cybergear as emu
from wheelleg.emulators.cybergear import CyberGear
from wheelleg.hil.cli import build_parser, main
from wheelleg.hil.commands import emulate

HOST = 0xFD


def request(ctype: int, motor: int = 1, data: bytes = bytes(8), host: int = HOST) -> can.Message:
    return can.Message(arbitration_id=cg.request_id(ctype, host, motor), data=data, is_extended_id=True)


def ask(motor: CyberGear, msg: can.Message, now_s: float = 0.0) -> can.Message:
    replies = motor.handle(msg, now_s)
    assert len(replies) == 1, replies
    return replies[0]


# -- type 4 shorter than 8 bytes ----------------------------------------------------------------
@pytest.mark.parametrize("dlc", range(0, 8))
def test_a_short_stop_stops(dlc):
    """The manual gives the stop's data (all zero; byte0 = 1 also clears faults), not its length."""
    motor = CyberGear(motor_id=1)
    ask(motor, request(cg.T_ENABLE))
    reply = cg.parse_reply_id(ask(motor, request(cg.T_STOP, data=bytes(dlc))).arbitration_id)
    assert motor.mode == emu.MODE_RESET and (reply.ctype, reply.mode) == (cg.T_FEEDBACK, emu.MODE_RESET)


@pytest.mark.parametrize("dlc, clears", [(0, False), (1, True), (3, True)])
def test_a_short_stop_clears_a_fault_only_with_byte0_1(dlc, clears):
    motor = CyberGear(motor_id=1)
    motor.inject_fault("FaultOverTemp")
    ask(motor, request(cg.T_STOP, data=bytes([1, 0, 0])[:dlc]))
    assert (motor.faults == frozenset()) == clears


# -- wheelleg emulate options --------------------------------------------------------------------
def test_a_uid_wider_than_64_bits_is_refused_with_one_line(capsys):
    assert main(["emulate", "cybergear", "-i", "virtual", "-c", "x", "--uid", hex(1 << 64)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "uid must fit the 64-bit MCU id" in err


def test_a_64_bit_uid_is_sent_whole():
    motor = CyberGear(motor_id=3, uid=0xFFFF_FFFF_FFFF_FFFE)
    assert int.from_bytes(ask(motor, request(cg.T_DEVICE_ID, 3)).data, "little") == 0xFFFF_FFFF_FFFF_FFFE


@pytest.mark.parametrize("argv, message", [
    (["--id", "1", "--id", "1"], "--id given twice"),
    (["--id", "1", "--id", "2", "--uid", "5"], "--uid names one motor"),
    (["--host", "300"], "host id must be 0..255"),
])
def test_bad_option_combinations_are_one_line_errors(capsys, argv, message):
    assert main(["emulate", "cybergear", "-i", "virtual", "-c", "x", *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_one_process_emulates_a_robots_four_motors():
    channel = f"emulate-{uuid.uuid4().hex}"
    args = build_parser().parse_args(["emulate", "cybergear", "-i", "virtual", "-c", channel,
                                      "--id", "1", "--id", "2", "--id", "3", "--id", "4"])
    stop, result = threading.Event(), {}
    thread = threading.Thread(target=lambda: result.update(rc=emulate.run(args, stop)))
    driver = can.Bus(interface="virtual", channel=channel)
    thread.start()
    try:
        seen = {}
        deadline = time.monotonic() + 20.0  # bounds a hang only
        while len(seen) < 4 and time.monotonic() < deadline:
            for motor in range(1, 5):
                if motor not in seen:
                    driver.send(request(cg.T_DEVICE_ID, motor))
            while (reply := driver.recv(timeout=0.2)) is not None:
                seen[cg.reply_motor(reply.arbitration_id)] = cg.target(reply.arbitration_id)
        assert seen == {1: cg.DEVICE_ID_TARGET, 2: cg.DEVICE_ID_TARGET, 3: cg.DEVICE_ID_TARGET, 4: cg.DEVICE_ID_TARGET}
    finally:
        stop.set()
        thread.join(timeout=20.0)
        driver.shutdown()
    assert result["rc"] == 0
