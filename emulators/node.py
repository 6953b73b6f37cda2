"""The devices that share one CAN bus, and the loop that serves them.

In the rig the plant calls ``service(now_s)`` with simulated time; alone
(``wheelleg emulate``) ``run_realtime`` serves the bus against the wall clock
and integrates each device's shaft itself. A device is anything with
``handle(msg, now_s)``, ``periodic(now_s)``, ``listens`` (False: it is not
handed received frames) and ``rx_filter`` (None: every frame; else only the
frames addressed to it: ``EmulatedDevice.rx_filter``), as ``EmulatedDevice``
has them; ``step_alone`` is used when present.
"""
from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Sequence

import can

from wheelleg.emulators.device import EmulatedDevice

log = logging.getLogger(__name__)

MAX_REALTIME_STEP_S = 0.02  # s; a stalled process integrates at most this much at once


class DeviceNode:
    """Devices on one bus: every frame goes to every device, replies go back out.

    The bus does not echo a node's own frames to it (python-can's default),
    so devices on one node do not hear each other, as they need not. A frame
    the bus refuses to send (full queue, bus off) is dropped and counted in
    ``send_errors``, like a real controller's lost transmit.

    Latency (plant overrides, rig only): a frame received by ``service`` at
    t reaches the devices at the first ``service`` at or after t +
    ``command_delay_s``; a frame a device sends at t goes on the bus at the
    first ``service`` at or after t + ``feedback_delay_s``, with what it said
    at t. So delays are taken on the service grid (each physics step in the rig).
    """

    def __init__(self, bus: can.BusABC, devices: Sequence[EmulatedDevice],
                 command_delay_s: float = 0.0, feedback_delay_s: float = 0.0):
        if not (command_delay_s >= 0.0 and feedback_delay_s >= 0.0):
            raise ValueError(f"delays must be >= 0 s, got {command_delay_s!r}, {feedback_delay_s!r}")
        self.bus = bus
        self.devices = list(devices)
        self.command_delay_s, self.feedback_delay_s = command_delay_s, feedback_delay_s
        self._inbound: deque[tuple[float, can.Message]] = deque()  # (due s, frame) for the devices
        self._outbound: deque[tuple[float, can.Message]] = deque()  # (due s, frame) for the bus
        self.frames_in = 0
        self.frames_out = 0
        self.send_errors = 0

    def dispatch(self, msg: can.Message, now_s: float) -> None:
        """Hand one received frame to every device that listens and whose ``rx_filter`` passes
        it, and send their replies."""
        field = value = None  # the identifier field last worked out for this frame, and its value
        for device in self.devices:
            if not device.listens:
                continue
            rx_filter = device.rx_filter
            if rx_filter is not None:
                extended, rx_field, attribute = rx_filter
                if bool(msg.is_extended_id) != extended:
                    continue
                if rx_field is not field:
                    field, value = rx_field, rx_field(msg.arbitration_id)
                if value != getattr(device, attribute):
                    continue
            replies = device.handle(msg, now_s)
            if replies:
                self._emit_all(replies, now_s)

    def send_periodic(self, now_s: float) -> None:
        """Send every device's periodic frames due by ``now_s``."""
        for device in self.devices:
            frames = device.periodic(now_s)
            if frames:
                self._emit_all(frames, now_s)

    def _emit_all(self, frames: list[can.Message], now_s: float) -> None:
        """Send ``frames`` (made at ``now_s``), or hold them for the feedback delay."""
        if self.feedback_delay_s > 0.0:
            for msg in frames:
                self._outbound.append((now_s + self.feedback_delay_s, msg))
        else:
            for msg in frames:
                self._send(msg)

    def service(self, now_s: float) -> int:
        """Drain the bus, answer each frame, then send periodic frames; returns frames received.

        Frames held back by a latency go first, in the order they were made.
        """
        if self._outbound:
            for msg in _due(self._outbound, now_s):
                msg.timestamp = now_s
                self._send(msg)
        if self._inbound:
            for msg in _due(self._inbound, now_s):
                self.dispatch(msg, now_s)
        received = 0
        recv = self.bus.recv
        while (msg := recv(timeout=0)) is not None:
            received += 1
            if self.command_delay_s > 0.0:
                self._inbound.append((now_s + self.command_delay_s, msg))
            else:
                self.dispatch(msg, now_s)
        self.frames_in += received
        self.send_periodic(now_s)
        return received

    def _send(self, msg: can.Message) -> None:
        try:
            self.bus.send(msg)
            self.frames_out += 1
        except can.CanError as exc:
            self.send_errors += 1
            if self.send_errors == 1:
                log.warning("frame dropped, the bus refused it: %s", exc)

    def run_realtime(self, stop: threading.Event, dt_s: float = 0.001) -> None:
        """Serve the bus against the wall clock until ``stop`` is set.

        Every ``dt_s`` the devices step alone (shaft and thermal model) and
        send their periodic frames; between ticks the loop blocks on the bus
        so that a request is answered as soon as it arrives, not at the next
        tick. Simulated time is wall time since the start.
        """
        if not dt_s > 0.0:
            raise ValueError(f"dt_s must be > 0, got {dt_s!r}")
        start = time.monotonic()
        last_step = 0.0
        next_tick = 0.0
        while not stop.is_set():
            now = time.monotonic() - start
            if now >= next_tick:
                step = min(now - last_step, MAX_REALTIME_STEP_S)
                for device in self.devices:
                    step_alone = getattr(device, "step_alone", None)
                    if step_alone is not None and step > 0.0:
                        step_alone(step, now)
                last_step = now
                self.send_periodic(now)
                next_tick += dt_s
                if next_tick <= now:  # fell behind: skip the missed ticks
                    next_tick = now + dt_s
            msg = self.bus.recv(timeout=max(0.0, next_tick - (time.monotonic() - start)))
            if msg is not None:
                self.frames_in += 1
                self.dispatch(msg, time.monotonic() - start)


_DUE_SLACK_S = 1e-9  # float sums of periods land a hair before the instant they name


def _due(queue: deque, now_s: float) -> list[can.Message]:
    """Pop and return the frames of ``queue`` ((due s, frame), in due order) due by ``now_s``."""
    out = []
    while queue and queue[0][0] <= now_s + _DUE_SLACK_S:
        out.append(queue.popleft()[1])
    return out
