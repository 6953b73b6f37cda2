"""A controller program on the robot's two CAN buses: its I/O and its clock.

Shared by both robots' controllers (``wheelleg.controller.node``,
``wheelleg.controller.quadruped.node``). Two clocks:

- sync mode (the rig's lockstep, docs/design.md): a tick runs when SYNC with the
  same counter has arrived on both buses; the controller's clock is the tick
  count times the control period;
- free-run mode (the robot, real time): a tick runs every control period of
  the monotonic clock.
"""
from __future__ import annotations

import time

import can

from wheelleg.dbc import CAN1, CAN2


class CanNode:
    """A controller program on its two buses, CAN1 (``bus1``) and CAN2 (``bus2``), and its clock.

    ``controller`` is the program without I/O: ``on_frame(msg, bus, now_s)``
    returns the SYNC counter of a SYNC frame (else None), ``tick(tick,
    now_s)`` returns a result whose ``frames`` map each bus to the frames to
    send, ``shutdown_frames(now_s)`` the frames that leave the robot safe, and
    ``prepare()``, if it has one, builds what its first frames would (``prepare``).
    """

    def __init__(self, bus1: can.BusABC, bus2: can.BusABC, controller, *, sync: bool = True,
                 period_s: float, listener=None):
        self.buses = {CAN1: bus1, CAN2: bus2}
        self.sync = sync
        self.controller = controller
        self.period_s = period_s
        self.listener = listener  # called as listener(bus, msg, sent: bool) for logging
        self._sync_tick = {CAN1: None, CAN2: None}
        self._last_tick = -1
        self._start = time.monotonic()
        self.ticks = 0
        self.last_result = None  # the last tick's result
        # When a list: (tick, monotonic s at its start) per tick, for the loop's timing statistics.
        self.tick_log: list[tuple[int, float]] | None = None

    def now(self) -> float:
        if self.sync:
            return max(self._last_tick, 0) * self.period_s
        return time.monotonic() - self._start

    def service(self, timeout_s: float = 0.0) -> bool:
        """Drain both buses; run a tick if one is due. True when a tick ran."""
        for name, bus in self.buses.items():
            while True:
                msg = bus.recv(timeout=0.0)
                if msg is None:
                    break
                self._received(name, msg)
        if self.sync:
            tick = self._sync_tick[CAN1]
            if tick is not None and tick == self._sync_tick[CAN2] and tick != self._last_tick:
                self._run_tick(tick, tick * self.period_s)
                return True
            return False
        now = self.now()
        due = int(now / self.period_s)
        if due > self._last_tick:
            self._run_tick(due, now)
            return True
        return False

    def _received(self, name: str, msg: can.Message) -> None:
        if self.listener:
            self.listener(name, msg, False)
        stamp = self._sync_tick[name]
        now = self.now() if not self.sync else ((stamp + 1) if stamp is not None else 0) * self.period_s
        tick = self.controller.on_frame(msg, name, now)
        if tick is not None:
            self._sync_tick[name] = tick

    def _run_tick(self, tick: int, now_s: float) -> None:
        if self.tick_log is not None:
            self.tick_log.append((tick, time.monotonic()))
        self._last_tick = tick
        result = self.controller.tick(tick, now_s)
        self.ticks += 1
        self.last_result = result
        for name, frames in result.frames.items():
            for msg in frames:
                self._send(name, msg)

    def _send(self, name: str, msg: can.Message) -> None:
        try:
            self.buses[name].send(msg)
        except can.CanError:
            pass  # a full queue or bus-off: the next tick sends again; detect notices silence
        if self.listener:
            self.listener(name, msg, True)

    def run(self, stop, idle_s: float = 0.0002) -> None:
        """Blocking loop until ``stop`` (a threading.Event) is set; disables on exit.

        Free-running, the period grid starts here, not when the node was built: the
        time between (opening buses, building the rest of the program) would otherwise
        make the first ticks late, counted as missed deadlines."""
        if not self.sync and self._last_tick < 0:
            self.prepare()
            self._start = time.monotonic()
        try:
            while not stop.is_set():
                if not self.service():
                    time.sleep(self._idle_s(idle_s))
        finally:
            self.disable()

    def prepare(self) -> None:
        """The program's first-use work done now (``controller.prepare()``, ~40 ms): a
        free-running loop does it before its period grid starts, so its first ticks run
        as long as the rest instead of a few ms late."""
        prepare = getattr(self.controller, "prepare", None)
        if prepare is not None:
            prepare()

    def _idle_s(self, poll_s: float) -> float:
        """How long to sleep when no tick ran: in sync mode poll every ``poll_s`` for
        SYNC; free-running, sleep to the next period boundary (frames that arrive
        meanwhile wait in the socket and are drained at the start of the tick)."""
        if self.sync:
            return poll_s
        return min(max(0.0, (self._last_tick + 1) * self.period_s - self.now()), self.period_s)

    def disable(self) -> None:
        """Send the frames that stop every motor (SIGINT/SIGTERM, end of a run)."""
        for name, frames in self.controller.shutdown_frames(self.now()).items():
            for msg in frames:
                self._send(name, msg)
