"""Transports: the in-process virtual bus with python-can's own on one channel, udp_multicast
buses that do not cross and do not echo (rig, emulate, controller), msgpack declared, an external
controller refused where none can join and given up on where none answers."""
import queue
import re
import signal
import subprocess
import sys
import threading
import time
import tomllib
from pathlib import Path

import can
import pytest

from wheelleg.controller.bus_args import BusChoice
from wheelleg.hil.bus.transport import FrameQueue, open_bus
from wheelleg.hil.cli import build_parser, main
from wheelleg.hil.commands import emulate
from wheelleg.hil.run.rig import Rig, RigConfig
from udp_groups import claimed_pair

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def groups():
    """Two udp_multicast groups and a port (CAN2 takes the next) no other test on this machine uses
    meanwhile (tests/udp_groups.py: fixed groups met another session's run of this file)."""
    with claimed_pair() as n:
        yield f"239.74.163.{n}", f"239.74.163.{n + 1}", 43300 + 2 * n


def _udp_pair(config: RigConfig):
    try:
        pytest.importorskip("msgpack")
        return [open_bus(config.interface, ch, **BusChoice(config.interface, config.channels,
                                                           config.bus_kwargs).kwargs_of(i))
                for i, ch in enumerate(config.channels)]
    except Exception as exc:  # noqa: BLE001 - a host without multicast
        pytest.skip(f"udp_multicast unavailable here: {exc}")


def test_lockstep_virtual_bus_and_pythons_can_virtual_bus_talk_both_ways_in_order():
    ours = open_bus("virtual", "transport-test-both-ways")
    theirs = can.Bus(interface="virtual", channel="transport-test-both-ways", receive_own_messages=False)
    try:
        for i in range(3):
            ours.send(can.Message(arbitration_id=0x100 + i, data=[i], is_extended_id=False))
            theirs.send(can.Message(arbitration_id=0x200 + i, data=[i, i], is_extended_id=False))
        got_theirs = [theirs.recv(timeout=1.0) for _ in range(3)]
        got_ours = [ours.recv(timeout=0) for _ in range(3)]
        assert [m.arbitration_id for m in got_theirs] == [0x100, 0x101, 0x102]
        assert [(m.arbitration_id, bytes(m.data)) for m in got_ours] == [(0x200, b"\0\0"), (0x201, b"\1\1"),
                                                                          (0x202, b"\2\2")]
        assert all(m.is_rx for m in got_ours + got_theirs)
        assert ours.recv(timeout=0) is None and theirs.recv(timeout=0.01) is None
    finally:
        ours.shutdown()
        theirs.shutdown()


def _fields(msg: can.Message) -> tuple:
    return (msg.timestamp, msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame, msg.is_error_frame,
            msg.channel, msg.dlc, type(msg.data), bytes(msg.data), msg.is_fd, msg.is_rx, msg.bitrate_switch,
            msg.error_state_indicator)


def test_a_frame_handed_over_arrives_as_the_copy_send_would_deliver():
    plant, controller = open_bus("virtual", "transport-test-owned"), open_bus("virtual", "transport-test-owned")
    try:
        plant.send(can.Message(1.5, 0x201, False, data=b"\1\2\3", is_rx=False))
        copied = controller.recv(timeout=0)
        mine = can.Message(1.5, 0x201, False, data=b"\1\2\3", is_rx=False)
        plant.send_owned(mine)
        handed = controller.recv(timeout=0)
        assert handed is mine and _fields(handed) == _fields(copied)
        assert (handed.channel, handed.is_rx, type(handed.data)) == (plant.channel_id, True, bytearray)
    finally:
        plant.shutdown()
        controller.shutdown()


def test_an_end_that_takes_frames_as_sent_gets_the_senders_frame_and_others_still_copies():
    plant, controller = open_bus("virtual", "transport-test-as-sent"), open_bus("virtual", "transport-test-as-sent")
    plant.take_as_sent()
    try:
        sent = can.Message(0.0, 0x200, False, data=b"\7")
        controller.send(sent)
        assert plant.poll() is sent
        third = open_bus("virtual", "transport-test-as-sent")  # two receivers: send_owned is send
        try:
            mine = can.Message(0.0, 0x1FF, False, data=b"\1", is_rx=False)
            controller.send_owned(mine)
            copy = third.recv(timeout=0)
            assert plant.poll() is mine and not mine.is_rx
            assert copy is not mine and (bytes(copy.data), copy.is_rx, copy.channel) == (b"\1", True,
                                                                                        controller.channel_id)
        finally:
            third.shutdown()
    finally:
        plant.shutdown()
        controller.shutdown()


def test_frame_queue_wakes_a_blocked_reader_and_times_out_when_empty():
    q = FrameQueue()
    with pytest.raises(queue.Empty):
        q.get(timeout=0.01)
    with pytest.raises(queue.Empty):
        q.get_nowait()
    assert q.pop() is None
    got = []
    reader = threading.Thread(target=lambda: got.append(q.get(timeout=10.0)))
    reader.start()
    threading.Event().wait(0.05)  # the reader is (most likely) blocked by now; either way it gets the frame
    q.put("frame")
    reader.join(timeout=10.0)
    assert got == ["frame"] and not reader.is_alive()
    q.put(1)
    q.put(2)
    assert (q.qsize(), q.pop(), q.get(), q.empty()) == (2, 1, 2, True)


def test_udp_multicast_buses_do_not_cross(groups):
    """Two groups on one UDP port are one bus; CAN2 takes the next port, so a frame on CAN1 stays there."""
    first, second, port = groups
    config = RigConfig(interface="udp_multicast", channels=(first, second), bus_kwargs={"port": port})
    can1, can2 = _udp_pair(config)
    listener = can.Bus(interface="udp_multicast", channel=first, port=port, receive_own_messages=False)
    try:
        can1.send(can.Message(arbitration_id=0x201, data=b"\x01", is_extended_id=False))
        got = listener.recv(2.0)
        assert got is not None and got.arbitration_id == 0x201  # multicast works on this host
        assert can2.recv(0.5) is None  # ... and CAN2 did not hear CAN1
    finally:
        for bus in (can1, can2, listener):
            bus.shutdown()


def test_the_two_buses_on_one_channel_are_refused(capsys):
    assert main(["run", "balance", "-c", "vcan0", "-c", "vcan0", "--no-plot"]) == 2
    assert "CAN1 and CAN2 are one channel ('vcan0')" in capsys.readouterr().err


def test_msgpack_is_declared_for_udp_multicast():
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    declared = project["dependencies"] + [d for ds in project["optional-dependencies"].values() for d in ds]
    assert any(d.split(">")[0].split("=")[0].strip() == "msgpack" for d in declared)


def test_external_controller_on_the_virtual_bus_is_refused_at_once(tmp_path, capsys):
    assert main(["run", "balance", "--external-controller", "--out", str(tmp_path), "--no-plot"]) == 2
    err = capsys.readouterr().err
    assert "--external-controller needs a bus another process can join" in err
    assert not any(tmp_path.iterdir())  # no rig was started (it would have opened its files)


def test_a_silent_external_controller_is_given_up_on(tmp_path, monkeypatch):
    """Elsewhere the rig waits a few seconds for the first heartbeat, then stops with the reason."""
    from wheelleg.hil import scenarios
    from wheelleg.hil.run import schedule

    monkeypatch.setattr(schedule, "CONTACT_S", 0.3)
    config = RigConfig(channels=("wl-silent-0", "wl-silent-1"), in_process_controller=False, deadline_s=0.05)
    rig = Rig(scenarios.get("balance"), config, tmp_path)
    with pytest.raises(schedule.NoController, match="no heartbeat from an external controller"):
        rig.run()
    assert rig.tick < 20  # it stopped near the start, not after the whole scenario
    assert (tmp_path / "balance.mcap").stat().st_size > 0  # the trace is closed and kept


def test_a_udp_multicast_run_logs_the_bytes_of_a_virtual_run(tmp_path, groups):
    """No crossing, no own echo: the same frames, order and times as on the in-process bus."""
    pytest.importorskip("msgpack")
    *groups, port = groups
    common = ["run", "balance", "--duration", "0.2", "--no-plot", "-q"]
    try:
        main([*common, "-i", "udp_multicast", "-c", groups[0], "-c", groups[1], "--bus-kwargs", f"port={port}",
              "--out", str(tmp_path / "udp")])
    except SystemExit as exc:
        pytest.skip(f"udp_multicast unavailable here: {exc.code}")
    main([*common, "--out", str(tmp_path / "virtual")])
    udp = (tmp_path / "udp" / "balance.log").read_text()
    udp = udp.replace(f" {groups[0]} ", " vcan0 ").replace(f" {groups[1]} ", " vcan1 ")
    assert udp == (tmp_path / "virtual" / "balance.log").read_text()


def test_emulated_devices_on_udp_multicast_do_not_hear_their_own_frames(capsys, groups):
    """An IMU alone on a group: every frame it sends comes back to its socket; none may count as heard."""
    pytest.importorskip("msgpack")
    group, _, port = groups
    args = build_parser().parse_args(["emulate", "imu", "-i", "udp_multicast", "-c", group,
                                      "--bus-kwargs", f"port={port}"])
    stop, result = threading.Event(), {}
    thread = threading.Thread(target=lambda: result.update(rc=emulate.run(args, stop)))
    thread.start()
    time.sleep(0.5)
    stop.set()
    thread.join(5.0)
    err = capsys.readouterr().err
    if result.get("rc") == 1:
        pytest.skip(f"udp_multicast unavailable here: {err.strip()}")
    counts = re.search(r"(\d+) frames in, (\d+) out", err)
    assert result["rc"] == 0 and counts is not None, err
    assert int(counts[2]) > 50 and int(counts[1]) == 0


def test_the_controller_on_udp_multicast_does_not_hear_its_own_frames(tmp_path, groups):
    """Alone on two groups, the free-running controller logs what it sends (T) and hears nothing (R)."""
    pytest.importorskip("msgpack")
    first, second, port = groups
    log = tmp_path / "robot.log"
    proc = subprocess.Popen([sys.executable, "-m", "wheelleg.controller", "-i", "udp_multicast",
                             "-c", first, "-c", second, "--bus-kwargs", f"port={port}",
                             "--log", str(log)], stderr=subprocess.PIPE, text=True, cwd=REPO)
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline and proc.poll() is None and " T\n" not in _text(log):
        time.sleep(0.1)
    time.sleep(0.3)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=10.0)
    if proc.returncode != 0:
        pytest.skip(f"udp_multicast unavailable here: {err.strip()[-200:]}")
    directions = [line.split()[-1] for line in _text(log).splitlines() if line.startswith("(")]
    assert directions.count("T") > 10
    assert directions.count("R") == 0


def _text(path: Path) -> str:
    return path.read_text() if path.exists() else ""
