"""``python -m wheelleg.controller`` as the robot runs it: the --log listener and the way out
(SIGINT/SIGTERM stop every motor before the process exits)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import can
import pytest

from wheelleg.controller import program
from wheelleg.controller import constants as C
from wheelleg.controller import messages
from wheelleg.controller.node import ControllerNode
from wheelleg.dbc import load_bus

REPO = Path(__file__).resolve().parents[1]
_RIG = load_bus("can1")
SYNC, HEARTBEAT = _RIG.get_message_by_name("SYNC"), _RIG.get_message_by_name("Heartbeat")
STOP_FRAMES = {"can1": [messages.wheel_currents({})],
               "can2": [messages.joint_stop(j.motor_id) for j in C.JOINTS]}


def _key(msg: can.Message) -> tuple:
    return msg.arbitration_id, msg.is_extended_id, bytes(msg.data)


# -- the log copy --------------------------------------------------------------------------------
def test_log_copy_of_a_sent_frame_is_tx_with_wall_clock_time():
    sent = messages.joint_stop(1, t_s=0.25)  # controller time 0.25 s
    before = time.time()
    copy = program.log_copy(sent, "can1", sent=True)
    assert before <= copy.timestamp <= time.time()
    assert copy.is_rx is False and copy.channel == "can1" and _key(copy) == _key(sent)
    assert sent.timestamp == 0.25 and sent.channel is None  # the node's frame is untouched


def test_log_copy_of_a_received_frame_keeps_its_interface_time():
    received = can.Message(arbitration_id=0x201, is_extended_id=False, data=b"\x01\x02", timestamp=1234.5,
                           is_rx=True, channel="vcan0")
    copy = program.log_copy(received, "can0", sent=False)
    assert (copy.is_rx, copy.timestamp, copy.channel, _key(copy)) == (True, 1234.5, "can0", _key(received))
    assert received.channel == "vcan0"


def test_log_of_a_node_marks_received_frames_r_and_sent_frames_t(tmp_path):
    """A ControllerNode ticking on SYNC over virtual buses, logged as `--log` does."""
    log = tmp_path / "controller.log"
    names = {"can1": "can0", "can2": "can1"}
    rig = {n: can.Bus(interface="virtual", channel=f"wl-main-{n}") for n in names}
    ctl = {n: can.Bus(interface="virtual", channel=f"wl-main-{n}") for n in names}
    writer = can.CanutilsLogWriter(log)
    node = ControllerNode(ctl["can1"], ctl["can2"], sync=True, listener=program.log_listener(writer, names))
    before = time.time()
    try:
        for tick in range(3):
            for bus in rig.values():
                bus.send(can.Message(arbitration_id=SYNC.frame_id, is_extended_id=False,
                                     data=SYNC.encode({"Tick": tick})))
            assert node.service()
        node.disable()
    finally:
        writer.stop()
        for bus in [*rig.values(), *ctl.values()]:
            bus.shutdown()
    after = time.time()
    logged = list(can.CanutilsLogReader(log))
    received = [m for m in logged if m.is_rx]
    sent = [m for m in logged if not m.is_rx]
    assert [m.arbitration_id for m in received] == [SYNC.frame_id] * 6
    heartbeats = [m for m in sent if m.arbitration_id == HEARTBEAT.frame_id]
    assert [(m.channel, HEARTBEAT.decode(m.data)["Tick"]) for m in heartbeats] == [
        (ch, tick) for tick in range(3) for ch in ("can0", "can1")]
    assert all(before - 0.001 <= m.timestamp <= after + 0.001 for m in sent)  # wall clock, not tick time
    tail = sent[-5:]
    assert [(m.channel, _key(m)) for m in tail] == [("can1", _key(f)) for f in STOP_FRAMES["can2"]] + [
        ("can0", _key(f)) for f in STOP_FRAMES["can1"]]


def test_signals_set_the_stop_event():
    stop = threading.Event()
    old = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        program.stop_on_signals(stop)
        os.kill(os.getpid(), signal.SIGTERM)
        assert stop.wait(2.0)
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


# -- the whole process: a signal, the motors stopped, exit 0 --------------------------------------
def _frames_after_last_heartbeat(frames: list[can.Message]) -> list[can.Message]:
    last = max(i for i, m in enumerate(frames) if m.arbitration_id == HEARTBEAT.frame_id)
    return frames[last + 1:]


def _start_controller(interface: str, wheels: str, joints: str, log: Path | None = None):
    argv = [sys.executable, "-m", "controller", "--interface", interface, "-c", wheels, "-c", joints]
    if log is not None:
        argv += ["--log", str(log)]
    return subprocess.Popen(argv, cwd=REPO, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signal_disables_the_motors_before_exit(tmp_path, sig):
    """The process free-runs alone on its (in-process virtual) buses; its --log shows the
    ticks, then after the signal the stop frames and nothing more."""
    log = tmp_path / "controller.log"
    proc = _start_controller("virtual", "wl-sig-can0", "wl-sig-can1", log)
    try:
        deadline = time.monotonic() + 60
        while (not log.exists() or log.stat().st_size < 4096) and time.monotonic() < deadline:
            assert proc.poll() is None, proc.stderr.read()
            time.sleep(0.05)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    assert "motors disabled" in err
    frames = list(can.CanutilsLogReader(log))
    assert len([m for m in frames if m.arbitration_id == HEARTBEAT.frame_id]) > 10  # it was ticking
    tail = _frames_after_last_heartbeat(frames)
    assert [(m.channel, _key(m), m.is_rx) for m in tail] == \
        [("wl-sig-can1", _key(f), False) for f in STOP_FRAMES["can2"]] + \
        [("wl-sig-can0", _key(f), False) for f in STOP_FRAMES["can1"]]


@pytest.mark.socketcan
def test_sigterm_stops_the_motors_on_vcan():
    """Over real SocketCAN: other sockets on vcan0/vcan1 see the stop frames go out."""
    from wheelleg.hil.bus import vcan
    import vcan_helpers

    reason = vcan.unavailable_reason()
    if reason is not None:
        pytest.fail(reason)
    seen: dict[str, list] = {"can1": [], "can2": []}
    done = threading.Event()

    def read(bus, frames):  # keep draining: a full socket buffer drops the newest frames
        while not done.is_set():
            msg = bus.recv(0.1)
            if msg is not None:
                frames.append(msg)
    with vcan_helpers.open_bus("vcan0") as wheels, vcan_helpers.open_bus("vcan1") as joints:
        readers = [threading.Thread(target=read, args=(bus, seen[name]))
                   for name, bus in (("can1", wheels), ("can2", joints))]
        for reader in readers:
            reader.start()
        proc = _start_controller("socketcan", "vcan0", "vcan1")
        try:
            deadline = time.monotonic() + 60
            while len(seen["can1"]) < 50 and time.monotonic() < deadline:
                assert proc.poll() is None, proc.stderr.read()
                time.sleep(0.05)
            proc.send_signal(signal.SIGTERM)
            _, err = proc.communicate(timeout=30)
        finally:
            proc.kill()
            time.sleep(0.5)
            done.set()
            for reader in readers:
                reader.join()
    assert proc.returncode == 0, err
    for bus, frames in seen.items():
        assert [_key(m) for m in _frames_after_last_heartbeat(frames)] == [_key(f) for f in STOP_FRAMES[bus]]
