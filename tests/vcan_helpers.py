"""Helpers the socketcan tests share: ``open_bus``, ``drain`` and ``CandumpCapture``
(a can-utils ``candump -L`` process with a known start and end in its output)."""
from __future__ import annotations

import os
import shutil
import subprocess
import time
from pathlib import Path

import can

from wheelleg.hil.bus.vcan import VcanError


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
