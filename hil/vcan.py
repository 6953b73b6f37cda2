"""Virtual SocketCAN channels (vcan0 = CAN1, vcan1 = CAN2) for the real-SocketCAN path.

``up()`` / ``down()`` create and remove the vcan links with ``ip link``;
``available()`` tells tests whether both channels exist and open as python-can
``socketcan`` buses.  Where the kernel cannot make vcan links (built without
CAN, a container, no CAP_NET_ADMIN), ``VcanError`` carries ``ip``'s own error
and the way to run the socketcan tests anyway: inside user-mode-linux with
``ci/uml-vcan.sh``.

Also small helpers the socketcan tests share: ``open_bus``, ``drain`` and
``CandumpCapture`` (a can-utils ``candump -L`` process with a known start
and end in its output).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path

import can

CHANNELS = ("vcan0", "vcan1")
TXQUEUELEN = 1000  # frames; the default 10 drops bursts with ENOBUFS on real CAN links
SYS_NET = Path("/sys/class/net")
UML_HINT = (
    "To run the socketcan tests anyway, boot user-mode-linux with real vcan0/vcan1:\n"
    "    apt-get install user-mode-linux kmod iproute2 can-utils\n"
    "    bash ci/uml-vcan.sh python3 -m pytest -q -m socketcan"
)


class VcanError(RuntimeError):
    """The kernel (or our rights) cannot give vcan links; the message says why and what to do."""


def _ip(*args: str) -> subprocess.CompletedProcess:
    ip = shutil.which("ip")
    if ip is None:
        raise VcanError("'ip' not found (apt-get install iproute2).\n" + UML_HINT)
    return subprocess.run([ip, *args], capture_output=True, text=True, check=False)


def exists(channel: str) -> bool:
    """True if the kernel has a network interface named ``channel``."""
    return (SYS_NET / channel).exists()


def txqueuelen(channel: str) -> int:
    """The interface's transmit queue length in frames (sysfs ``tx_queue_len``)."""
    return int((SYS_NET / channel / "tx_queue_len").read_text())


def _try_modprobe() -> str:
    """Load the vcan module if modprobe exists; returns its error text ('' on success)."""
    modprobe = shutil.which("modprobe")
    if modprobe is None:
        return "modprobe not found"
    done = subprocess.run([modprobe, "vcan"], capture_output=True, text=True, check=False)
    return "" if done.returncode == 0 else (done.stderr.strip() or f"exit status {done.returncode}")


def _add(channel: str) -> None:
    """``ip link add dev <channel> type vcan``, retried once after ``modprobe vcan``."""
    first = _ip("link", "add", "dev", channel, "type", "vcan")
    if first.returncode == 0:
        return
    if _try_modprobe() == "":
        retry = _ip("link", "add", "dev", channel, "type", "vcan")
        if retry.returncode == 0:
            return
    raise VcanError(_explain(channel, first.stderr.strip()))


def _explain(channel: str, ip_error: str) -> str:
    why = "this kernel has no vcan support (built without CAN, or a container without the module)"
    if "not permitted" in ip_error.lower() or "permission" in ip_error.lower():
        why = "creating network links needs root or CAP_NET_ADMIN (try sudo), or this is a container"
    return (f"cannot create {channel}: `ip link add dev {channel} type vcan` failed: {ip_error}\n"
            f"Likely cause: {why}.\n{UML_HINT}")


def up(channels: tuple[str, ...] = CHANNELS, txqueuelen_frames: int = TXQUEUELEN) -> list[str]:
    """Create (if absent) each vcan link, set its txqueuelen and bring it up.

    Returns one line per channel saying what was done. Raises ``VcanError``.
    """
    report = []
    for channel in channels:
        created = not exists(channel)
        if created:
            _add(channel)
        done = _ip("link", "set", channel, "txqueuelen", str(txqueuelen_frames), "up")
        if done.returncode != 0:
            raise VcanError(f"`ip link set {channel} txqueuelen {txqueuelen_frames} up` failed: "
                            f"{done.stderr.strip()}\n{UML_HINT}")
        verb = "created" if created else "already there,"
        report.append(f"{channel}: {verb} up, txqueuelen {txqueuelen(channel)}")
    return report


def down(channels: tuple[str, ...] = CHANNELS) -> list[str]:
    """Delete each link that exists. Returns one line per channel. Raises ``VcanError``."""
    report = []
    for channel in channels:
        if not exists(channel):
            report.append(f"{channel}: not present")
            continue
        done = _ip("link", "delete", "dev", channel)
        if done.returncode != 0:
            raise VcanError(f"`ip link delete dev {channel}` failed: {done.stderr.strip()}")
        report.append(f"{channel}: deleted")
    return report


def unavailable_reason(channels: tuple[str, ...] = CHANNELS) -> str | None:
    """Why the socketcan tests cannot run here, or None if every channel opens."""
    for channel in channels:
        if not exists(channel):
            return f"{channel} does not exist (run `wheelleg vcan up`).\n{UML_HINT}"
        try:
            can.Bus(interface="socketcan", channel=channel).shutdown()
        except (OSError, can.CanError) as exc:
            return f"{channel} exists but python-can cannot open it: {exc}\n{UML_HINT}"
    return None


def available(channels: tuple[str, ...] = CHANNELS) -> bool:
    """True if every channel exists and python-can opens a socketcan bus on it."""
    return unavailable_reason(channels) is None


# -- helpers for the socketcan tests ---------------------------------------------------------
def open_bus(channel: str, **kwargs) -> can.BusABC:
    """A python-can socketcan bus on ``channel`` (own frames not echoed back)."""
    kwargs.setdefault("receive_own_messages", False)
    return can.Bus(interface="socketcan", channel=channel, **kwargs)


def drain(bus: can.BusABC, count: int, timeout_s: float = 5.0) -> list[can.Message]:
    """Receive up to ``count`` frames, giving up ``timeout_s`` (wall clock) after the last one."""
    frames: list[can.Message] = []
    while len(frames) < count:
        msg = bus.recv(timeout_s)
        if msg is None:
            break
        frames.append(msg)
    return frames


MARK_ID = 0x7FF  # standard id of CandumpCapture's start/end marker frames
MARK_START, MARK_END = b"START", b"END"


class CandumpCapture:
    """``candump -L <channel>`` writing to ``path``; ``frame_lines()`` gives what came between.

    candump gives no sign that its socket is bound, so ``start()`` sends a
    marker frame (id 0x7FF, data "START") until candump logs it; ``stop()``
    sends an "END" marker, waits for it, then ends candump.  The frames sent
    between the two are exactly the log lines between the markers.
    """

    def __init__(self, channel: str, path: str | os.PathLike, timeout_s: float = 10.0):
        if shutil.which("candump") is None:
            raise VcanError("candump not found (apt-get install can-utils)")
        self.channel, self.path, self.timeout_s = channel, Path(path), timeout_s
        self._proc: subprocess.Popen | None = None
        self._marker_bus: can.BusABC | None = None

    def start(self) -> "CandumpCapture":
        self._file = open(self.path, "w")
        self._proc = subprocess.Popen(["candump", "-L", self.channel], stdout=self._file,
                                      stderr=subprocess.PIPE)
        self._marker_bus = open_bus(self.channel)
        self._mark(MARK_START, repeat=True)
        return self

    def stop(self) -> None:
        try:
            if self._marker_bus is not None and self._proc is not None and self._proc.poll() is None:
                self._mark(MARK_END, repeat=False)
        finally:
            self._close()

    def _close(self) -> None:
        if self._proc is not None:
            self._proc.terminate()
            self._proc.wait(self.timeout_s)
        if self._marker_bus is not None:
            self._marker_bus.shutdown()
        self._file.close()
        self._proc = self._marker_bus = None

    def _mark(self, data: bytes, repeat: bool) -> None:
        marker = f"{MARK_ID:03X}#{data.hex().upper()}"
        deadline = time.monotonic() + self.timeout_s
        self._marker_bus.send(can.Message(arbitration_id=MARK_ID, is_extended_id=False, data=data))
        while marker not in self.path.read_text():
            if self._proc.poll() is not None:
                raise VcanError(f"candump exited ({self._proc.returncode}): "
                                f"{self._proc.stderr.read().decode(errors='replace').strip()}")
            if time.monotonic() > deadline:
                raise VcanError(f"candump logged no {data.decode()} marker within {self.timeout_s} s")
            time.sleep(0.05)
            if repeat:
                self._marker_bus.send(can.Message(arbitration_id=MARK_ID, is_extended_id=False,
                                                  data=data))

    def frame_lines(self) -> list[str]:
        """The log's lines after the last START marker and before the END marker."""
        lines = self.path.read_text().splitlines()
        start = max(i for i, line in enumerate(lines) if _is_marker(line, MARK_START))
        end = next(i for i, line in enumerate(lines) if _is_marker(line, MARK_END))
        return lines[start + 1:end]

    def __enter__(self) -> "CandumpCapture":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def _is_marker(line: str, data: bytes) -> bool:
    return line.split()[2:3] == [f"{MARK_ID:03X}#{data.hex().upper()}"]
