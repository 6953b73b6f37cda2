"""Real SocketCAN: vcan0/vcan1 links, python-can over them, can-utils candump/canplayer.

Tests marked ``socketcan`` need real vcan0/vcan1; they are deselected by
default.  Run them with ``wheelleg vcan up && python3 -m pytest -m socketcan``
or, where the kernel has no CAN, ``wheelleg vcan uml -- python3 -m pytest -q -m
socketcan``.  The unmarked tests check the error path and the UML script's
exit status, and run anywhere.
"""
from __future__ import annotations

import argparse
import os
import select
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import can
import pytest

from wheelleg.hil.bus import vcan
from wheelleg.hil.record.frame import Frame

import vcan_helpers
from wheelleg.hil.commands import vcan as vcan_command

REPO = Path(__file__).resolve().parents[1]
UML_SCRIPT = vcan.UML_RUNNER
BURST_FRAMES = 500


# -- the clear-error path (no kernel CAN needed) -------------------------------------------
def _fake_ip(returncode: int, stderr: str):
    def ip(*args):
        return subprocess.CompletedProcess(["ip", *args], returncode, "", stderr)
    return ip


@pytest.mark.parametrize("ip_error, cause", [
    ("Error: Unknown device type.", "no vcan support"),
    ("RTNETLINK answers: Operation not permitted", "CAP_NET_ADMIN"),
])
def test_up_error_quotes_ip_and_says_how_to_run_anyway(monkeypatch, ip_error, cause):
    monkeypatch.setattr(vcan, "exists", lambda channel: False)
    monkeypatch.setattr(vcan, "_ip", _fake_ip(2, ip_error + "\n"))
    monkeypatch.setattr(vcan, "_try_modprobe", lambda: "modprobe: FATAL: Module vcan not found")
    with pytest.raises(vcan.VcanError) as info:
        vcan.up(("vcan0",))
    text = str(info.value)
    assert ip_error in text
    assert cause in text
    assert "wheelleg vcan uml -- python3 -m pytest -q -m socketcan" in text


def _run_command(argv: list[str]) -> int:
    parser = argparse.ArgumentParser()
    vcan_command.add_arguments(parser)
    return vcan_command.run(parser.parse_args(argv))


def test_vcan_up_command_exits_nonzero_with_the_reason(monkeypatch, capsys):
    monkeypatch.setattr(vcan, "exists", lambda channel: False)
    monkeypatch.setattr(vcan, "_ip", _fake_ip(2, "Error: Unknown device type.\n"))
    monkeypatch.setattr(vcan, "_try_modprobe", lambda: "modprobe not found")
    assert _run_command(["up"]) == 1
    err = capsys.readouterr().err
    assert "Error: Unknown device type." in err and "wheelleg vcan uml" in err


def test_up_retries_after_modprobe(monkeypatch):
    calls = []
    def ip(*args):
        calls.append(args)
        ok = args[:2] == ("link", "set") or len([c for c in calls if c[1] == "add"]) > 1
        return subprocess.CompletedProcess(["ip", *args], 0 if ok else 2, "", "Error: Unknown device type.")
    monkeypatch.setattr(vcan, "exists", lambda channel: False)
    monkeypatch.setattr(vcan, "_ip", ip)
    monkeypatch.setattr(vcan, "_try_modprobe", lambda: "")
    monkeypatch.setattr(vcan, "txqueuelen", lambda channel: 1000)
    assert vcan.up(("vcan0",)) == ["vcan0: created up, txqueuelen 1000"]
    assert calls == [("link", "add", "dev", "vcan0", "type", "vcan")] * 2 + [
        ("link", "set", "vcan0", "txqueuelen", "1000", "up")]


def test_txqueuelen_must_be_positive(capsys):
    assert _run_command(["up", "--txqueuelen", "0"]) == 2
    assert "--txqueuelen" in capsys.readouterr().err


def test_missing_channel_is_unavailable_with_hint():
    name = "wlnone9"  # interface names are at most 15 characters; this one is never created
    assert not vcan.exists(name)
    assert not vcan.available((name,))
    reason = vcan.unavailable_reason((name,))
    assert name in reason and "wheelleg vcan uml" in reason


def test_run_on_a_missing_channel_exits_with_the_reason_and_writes_nothing(tmp_path):
    from wheelleg.hil.cli import main

    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main(["run", "balance", "--interface", "socketcan", "-c", "wlnone8", "-c", "wlnone9",
              "--out", str(out), "--no-plot"])
    assert "cannot open socketcan channel 'wlnone8'" in str(exc.value.code)
    assert not out.exists() or not any(out.iterdir())


def test_status_command_fails_for_a_missing_channel(capsys):
    assert _run_command(["status", "-c", "wlnone9"]) == 1
    assert "wlnone9 does not exist" in capsys.readouterr().out


def test_down_leaves_absent_channels_alone(monkeypatch):
    monkeypatch.setattr(vcan, "_ip", lambda *a: pytest.fail(f"ip called: {a}"))
    assert vcan.down(("wlnone9",)) == ["wlnone9: not present"]


def test_real_ip_error_is_quoted_where_the_kernel_cannot():
    """On a host without vcan (like this one), the message carries ip's own words."""
    if shutil.which("ip") is None:
        pytest.skip("iproute2 not installed")
    probe = subprocess.run(["ip", "link", "add", "dev", "wlprobe0", "type", "vcan"],
                           capture_output=True, text=True)
    if probe.returncode == 0:
        subprocess.run(["ip", "link", "delete", "dev", "wlprobe0"], check=True)
        pytest.skip("this kernel makes vcan links: no error path to see")
    with pytest.raises(vcan.VcanError) as info:
        vcan.up(("wlprobe0",))
    assert probe.stderr.strip() in str(info.value)


def test_vcan_uml_without_a_command_is_a_usage_error(capsys):
    assert _run_command(["uml", "--"]) == 2
    assert _run_command(["uml"]) == 2
    assert "wheelleg vcan uml -- CMD" in capsys.readouterr().err


def test_uml_script_fails_clearly_without_linux_uml():
    env = dict(os.environ, UML_VCAN_KERNEL="/nonexistent/linux.uml")
    done = subprocess.run(["bash", str(UML_SCRIPT), "true"], capture_output=True, text=True,
                          env=env, timeout=60)
    assert done.returncode == 125
    assert "apt-get install user-mode-linux" in done.stderr


@pytest.mark.skipif(shutil.which("linux.uml") is None, reason="user-mode-linux not installed")
@pytest.mark.slow
def test_uml_script_streams_output_and_returns_the_command_status(tmp_path):
    """One boot: vcan links inside, quoting and env kept, CMD's status is the script's."""
    probe = ("import os, sys; from wheelleg.hil.bus import vcan; "
             "print('ENV', os.environ['WL_PROBE'], vcan.txqueuelen('vcan0'), vcan.txqueuelen('vcan1'),"
             " os.getcwd(), sys.executable); sys.exit(7)")
    env = dict(os.environ, WL_PROBE="a b'c", UML_VCAN_ENV="WL_PROBE", UML_VCAN_TIMEOUT="240")
    done = subprocess.run([sys.executable, "-m", "wheelleg.hil.cli", "vcan", "uml", "--", sys.executable, "-c", probe],
                          cwd=REPO,
                          capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 7, done.stderr
    assert f"ENV a b'c 1000 1000 {REPO} {sys.executable}" in done.stdout.splitlines()
    assert "\r" not in done.stdout


# -- real SocketCAN (vcan0/vcan1) ------------------------------------------------------------
@pytest.fixture
def real_vcan():
    reason = vcan.unavailable_reason()
    if reason is not None:
        pytest.fail(reason)  # asked for socketcan tests on a host that cannot run them


def _frames() -> list[can.Message]:
    """Standard and extended ids, 0..8 data bytes, distinct payloads."""
    out = []
    for i in range(9):
        out.append(can.Message(arbitration_id=0x200 + i, is_extended_id=False, data=bytes(range(i))))
        out.append(can.Message(arbitration_id=0x0200FD01 + (i << 8), is_extended_id=True,
                               data=bytes((0xA0 + i,) * i)))
    return out


def _key(msg) -> tuple:
    return msg.arbitration_id, msg.is_extended_id, bytes(msg.data)


@pytest.mark.socketcan
@pytest.mark.parametrize("channel", vcan.CHANNELS)
def test_python_can_send_receive(real_vcan, channel):
    with vcan_helpers.open_bus(channel) as rx, vcan_helpers.open_bus(channel) as tx:
        sent = _frames()
        for msg in sent:
            tx.send(msg)
        got = vcan_helpers.drain(rx, len(sent))
        assert [_key(m) for m in got] == [_key(m) for m in sent]
        assert all(m.channel == channel and m.dlc == len(m.data) for m in got)
        assert rx.recv(0.2) is None  # nothing more, in particular no echo of our own frames


@pytest.mark.socketcan
def test_channels_are_separate_buses(real_vcan):
    with vcan_helpers.open_bus("vcan0") as rx0, vcan_helpers.open_bus("vcan1") as tx1, vcan_helpers.open_bus("vcan1") as rx1:
        tx1.send(can.Message(arbitration_id=0x123, is_extended_id=False, data=b"\x01"))
        assert _key(rx1.recv(5.0)) == (0x123, False, b"\x01")
        assert rx0.recv(0.2) is None


@pytest.mark.socketcan
@pytest.mark.parametrize("channel", vcan.CHANNELS)
def test_txqueuelen_is_1000(real_vcan, channel):
    assert vcan.txqueuelen(channel) == vcan.TXQUEUELEN


@pytest.mark.socketcan
def test_burst_of_500_frames_arrives_whole(real_vcan):
    """500 back-to-back sends: none fails (ENOBUFS), all arrive in order."""
    sent = [can.Message(arbitration_id=0x100 + i % 0x100, is_extended_id=False,
                        data=i.to_bytes(2, "little") * 4) for i in range(BURST_FRAMES)]
    with vcan_helpers.open_bus("vcan0") as rx, vcan_helpers.open_bus("vcan0") as tx:
        got: list[can.Message] = []
        reader = threading.Thread(target=lambda: got.extend(vcan_helpers.drain(rx, BURST_FRAMES)))
        reader.start()
        for msg in sent:
            tx.send(msg, timeout=1.0)
        reader.join(60)
    assert [_key(m) for m in got] == [_key(m) for m in sent]


def _candump_module():
    from wheelleg.hil.record import candump
    return candump


@pytest.mark.socketcan
def test_candump_capture_reads_back_as_our_own_log(real_vcan, tmp_path):
    """can-utils candump records what python-can sent; wheelleg.hil.record.candump reads that capture
    exactly as it reads the rig's own log of the same frames."""
    candump = _candump_module()
    sent = _frames()
    capture = vcan_helpers.CandumpCapture("vcan0", tmp_path / "capture.log")
    with capture, vcan_helpers.open_bus("vcan0") as tx:
        for msg in sent:
            tx.send(msg)
    assert len(capture.frame_lines()) == len(sent)
    captured = [f for f in candump.CandumpReader(capture.path) if f.arbitration_id != vcan_helpers.MARK_ID]

    own_log = tmp_path / "own.log"
    with candump.CandumpWriter(own_log) as writer:
        for i, msg in enumerate(sent):
            writer.write(Frame.of(msg, "vcan0", i * 1000))
    ours = list(candump.CandumpReader(own_log))

    def fields(f):
        return f.channel, f.arbitration_id, f.is_extended, f.data, f.dlc, f.is_error, f.is_remote
    assert [fields(f) for f in captured] == [fields(f) for f in ours]
    assert [(f.arbitration_id, f.is_extended, f.data) for f in captured] == [_key(m) for m in sent]
    times = [f.t_ns for f in captured]
    assert times == sorted(times)


@pytest.mark.socketcan
@pytest.mark.parametrize("log_channel, target", [("vcan0", "vcan0"), ("can1", "vcan1")])
def test_canplayer_replays_a_rig_log(real_vcan, tmp_path, log_channel, target):
    """canplayer puts a log written by wheelleg.hil.record.candump onto the bus; python-can reads the same frames."""
    if shutil.which("canplayer") is None:
        pytest.fail("canplayer not found (apt-get install can-utils)")
    candump = _candump_module()
    sent = _frames()
    log = tmp_path / "rig.log"
    with candump.CandumpWriter(log) as writer:
        for i, msg in enumerate(sent):  # 1 ms apart: canplayer keeps the log's timing
            writer.write(Frame.of(msg, log_channel, 1_700_000_000_000_000_000 + i * 1_000_000))
    with vcan_helpers.open_bus(target) as rx:
        done = subprocess.run(["canplayer", "-I", str(log), f"{target}={log_channel}"],
                              capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        got = vcan_helpers.drain(rx, len(sent))
        assert rx.recv(0.2) is None
    assert [_key(m) for m in got] == [_key(m) for m in sent]


# -- the controller over socketcan ---------------------------------------------------------
def _controller_exchange(rig_buses: dict, ctl_buses: dict, ticks: int) -> dict:
    """Lockstep without a plant: SYNC k on both buses, the ControllerNode ticks, and the
    rig collects what it sends up to its heartbeat. Returns {bus: [(id, ext, data), ...]}."""
    from wheelleg.controller.node import ControllerNode
    from wheelleg.dbc import load_bus

    rig_db = load_bus("can1")
    sync, heartbeat = rig_db.get_message_by_name("SYNC"), rig_db.get_message_by_name("Heartbeat")
    node = ControllerNode(ctl_buses["can1"], ctl_buses["can2"], sync=True)
    seen = {name: [] for name in rig_buses}
    for tick in range(ticks):
        for bus in rig_buses.values():
            bus.send(can.Message(arbitration_id=sync.frame_id, is_extended_id=False,
                                 data=sync.encode({"Tick": tick})))
        for _ in range(500):  # frames may still be in flight: poll, bounded
            if node.service(0.0):
                break
            threading.Event().wait(0.01)
        else:
            pytest.fail(f"controller ran no tick for SYNC {tick}")
        for name, bus in rig_buses.items():
            while True:
                msg = bus.recv(5.0)
                assert msg is not None, f"no heartbeat on {name} for tick {tick}"
                seen[name].append(_key(msg))
                if msg.arbitration_id == heartbeat.frame_id:
                    assert heartbeat.decode(msg.data)["Tick"] == tick
                    break
    return seen


@pytest.mark.socketcan
def test_controller_over_socketcan_sends_what_it_sends_over_virtual(real_vcan):
    ticks = 5
    virtual = {name: (can.Bus(interface="virtual", channel=f"wl-{name}"),
                      can.Bus(interface="virtual", channel=f"wl-{name}")) for name in ("can1", "can2")}
    try:
        expected = _controller_exchange({n: b[0] for n, b in virtual.items()},
                                        {n: b[1] for n, b in virtual.items()}, ticks)
    finally:
        for pair in virtual.values():
            for bus in pair:
                bus.shutdown()
    channel_of = {"can1": "vcan0", "can2": "vcan1"}
    rig = {n: vcan_helpers.open_bus(ch) for n, ch in channel_of.items()}
    ctl = {n: vcan_helpers.open_bus(ch) for n, ch in channel_of.items()}
    try:
        got = _controller_exchange(rig, ctl, ticks)
    finally:
        for bus in [*rig.values(), *ctl.values()]:
            bus.shutdown()
    assert got == expected
    assert all(len(frames) >= ticks for frames in got.values())


# -- the device emulators over socketcan -----------------------------------------------------
def _bus_pair(transport: str, channel: str) -> tuple[can.BusABC, can.BusABC]:
    """(host side, device side) on one bus of the given transport."""
    if transport == "socketcan":
        return vcan_helpers.open_bus(channel), vcan_helpers.open_bus(channel)
    return (can.Bus(interface="virtual", channel=f"wl-{channel}"),
            can.Bus(interface="virtual", channel=f"wl-{channel}"))


def _wait_readable(bus: can.BusABC, timeout_s: float = 5.0) -> None:
    """Block until a socketcan bus has a frame; a virtual bus has it as soon as it is sent."""
    try:
        fd = bus.fileno()
    except NotImplementedError:
        return
    ready, _, _ = select.select([fd], [], [], timeout_s)
    assert ready, "the device side received nothing"


def _serve(transport: str, channel: str, device, requests: list[can.Message],
           feedback_times_s: tuple[float, ...] = ()) -> list[can.Message]:
    """Each request from a host bus to a DeviceNode serving ``device`` (at t = 0 s), then
    the node's periodic frames at ``feedback_times_s``; returns what the host received."""
    from wheelleg.emulators import node as node_module
    host, device_bus = _bus_pair(transport, channel)
    try:
        node = node_module.DeviceNode(device_bus, [device])
        for request in requests:
            host.send(request)
            _wait_readable(device_bus)
            assert node.service(0.0) == 1
        for t_s in feedback_times_s:
            node.service(t_s)
        return vcan_helpers.drain(host, 10_000, timeout_s=0.3)
    finally:
        host.shutdown()
        device_bus.shutdown()


def _same_on_both_transports(channel, make_device, requests, feedback_times_s=()) -> list:
    """What the host receives over socketcan, checked equal to the virtual bus's."""
    over_virtual = _serve("virtual", channel, make_device(), requests, feedback_times_s)
    over_vcan = _serve("socketcan", channel, make_device(), requests, feedback_times_s)
    assert [_key(m) for m in over_vcan] == [_key(m) for m in over_virtual]
    return over_vcan


@pytest.mark.socketcan
def test_cybergear_emulator_answers_over_vcan1(real_vcan):
    """Enable, a type-1 torque command, stop: one type-2 reply each, run mode then reset."""
    from wheelleg.emulators import cybergear as emulator
    from wheelleg.controller import constants as C
    from wheelleg.controller import messages
    from wheelleg.dbc import cybergear as cg

    motor = C.JOINTS[0].motor_id
    enable = messages.joint_enable(motor)
    requests = [enable, messages.joint_torque(motor, 0.5), messages.joint_stop(motor)]
    replies = _same_on_both_transports("vcan1", lambda: emulator.CyberGear(motor_id=motor), requests)
    ids = [cg.parse_reply_id(m.arbitration_id) for m in replies]
    assert all(m.is_extended_id and m.dlc == 8 for m in replies)
    assert [(r.ctype, r.motor_id, r.host) for r in ids] == [
        (cg.T_FEEDBACK, motor, cg.request_host(enable.arbitration_id))] * 3
    assert [r.mode for r in ids] == [emulator.MODE_RUN, emulator.MODE_RUN, emulator.MODE_RESET]


@pytest.mark.socketcan
def test_c620_emulator_answers_over_vcan0(real_vcan):
    """A current command, then 1 kHz feedback frames that report that current."""
    from wheelleg.emulators import c620 as emulator
    from wheelleg.controller import constants as C
    from wheelleg.controller import messages
    from wheelleg.dbc import load_file

    esc = C.WHEELS[0].esc_id
    current_a = 2.0
    feedback = load_file("c620.dbc").get_message_by_name(f"C620_Feedback_{esc}")
    frames = _same_on_both_transports("vcan0", lambda: emulator.C620(esc_id=esc),
                                      [messages.wheel_currents({esc: current_a})],
                                      feedback_times_s=(0.001, 0.002, 0.003))
    assert [m.arbitration_id for m in frames] == [feedback.frame_id] * 4  # t = 0 and 3 periods
    lsb_a = feedback.get_signal_by_name("TorqueCurrent").scale
    for m in frames:
        assert abs(feedback.decode(m.data)["TorqueCurrent"] - current_a) <= lsb_a
