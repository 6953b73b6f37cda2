"""How a lockstep run moves: the schedule owns the run's clock and drives the rig tick by tick.

Lockstep: each control period the rig sends SYNC(T) on both buses after the
period's feedback; the controller runs one tick per SYNC and ends it with a
heartbeat on both buses; the plant handles the commands that came before the
heartbeats (they are in bus order) and only then steps the physics.

Lockstep is not real time: a slow or loaded machine (user-mode-linux on a busy
host stalls its processes for over a second) must not fail a program, only a
silent one may. So a program in another process that answered its last tick
gets up to ``patience_s`` of wall time for this one's heartbeats; unanswered
that long it is silent: a deadline miss (in the trace and the summary), and
until it answers again each tick waits only ``deadline_s`` for it. A program
the rig started that exits meanwhile ends the run at once (``ProgramExited``).

- ``Lockstep``: python-can's in-process virtual bus. With the in-process
  controller the rig hands it the turn itself instead of sleeping: the same
  frames in the same order, just no thread switches.
- ``HeldLockstep``: a real transport (SocketCAN). The plant holds each bus's
  frames until both heartbeats are in and then takes them in the virtual
  bus's order (hil/bus/held_bus.py): the same bytes in the recording on
  every transport.

Real time has its own schedule: hil/run/realtime.py.
"""
from __future__ import annotations

import time

import can

from wheelleg.dbc import load_file
from wheelleg.dbc.codec import MessageCodec
from wheelleg.hil.bus.held_bus import HeldBus
from wheelleg.hil.bus.plant_bus import SimClock

_HEARTBEAT = load_file("rig.dbc").get_message_by_name("Heartbeat")  # every robot's lockstep frame
_HEARTBEAT_CODEC = MessageCodec.of(_HEARTBEAT)  # compiled: two heartbeats a tick through cantools cost ~15 us
_HEARTBEAT_ID = _HEARTBEAT.frame_id  # read once: a cantools property, asked of every frame the controller sends
POLL_S = 0.00005  # s between polls while the heartbeats of an external controller are awaited
CONTACT_S = 3.0  # s of wall time an external controller has to send its first heartbeat
RESYNC_S = 0.1  # s between the SYNC(0)s the rig repeats until a program it started answers the first
PATIENCE_S = 10.0  # wall s a tick waits for a program that answered the tick before (a loaded UML stalls > 1 s)


class NoController(RuntimeError):
    """An external controller never answered: no heartbeat within ``CONTACT_S`` of the start."""


class HeartbeatWatch:
    """The lockstep watch, a plant-bus stage: the last heartbeat tick the controller sent on one bus."""

    def __init__(self):
        self.tick = -1

    def outbound(self, frames: list[can.Message]) -> list[can.Message]:
        return frames

    def inbound(self, msg: can.Message) -> bool:
        if msg.arbitration_id == _HEARTBEAT_ID:  # the common case, a frame that is none, cheaply
            self.note(msg)
        return True

    def note(self, msg: can.Message) -> None:
        if msg.arbitration_id == _HEARTBEAT_ID and not msg.is_extended_id and msg.dlc == 8:
            try:
                self.tick = _HEARTBEAT_CODEC.decode(bytes(msg.data))["Tick"]
            except Exception:
                pass  # a malformed heartbeat counts as none: the deadline catches it


class Lockstep:
    """Lockstep on the in-process bus; owns the run's ``clock``."""

    def __init__(self, period_s: float, physics_dt_s: float, deadline_s: float, patience_s: float | None = None):
        """``deadline_s``, ``patience_s`` (None: ``PATIENCE_S``): wall s a tick waits for a program in another
        process that is silent (missed its last tick, or not heard yet), and for one that answered its last tick."""
        self.period_s, self.physics_dt_s, self.deadline_s = period_s, physics_dt_s, deadline_s
        self.patience_s = max(PATIENCE_S if patience_s is None else patience_s, deadline_s)
        self.clock = SimClock()
        self.watches: dict[str, HeartbeatWatch] = {}
        self.silent_s = 0.0  # wall time an external controller has been silent from the start (s)
        self.heard = False  # a heartbeat came: the controller is there
        self.answering = False  # the last tick's heartbeats came: the next one waits up to ``patience_s``

    def bus_end(self, bus: str, end: can.BusABC):
        """The transport end the plant reads ``bus`` through, and its lockstep watch."""
        self.watches[bus] = HeartbeatWatch()
        return end

    def run(self, rig, ticks: int) -> None:
        for tick in range(ticks):
            self.step_tick(rig, tick)
            if rig.stop_requested:  # a watcher ended the run (the viewer's window closed)
                break

    def step_tick(self, rig, tick: int) -> None:
        t_s = tick * self.period_s
        self.clock.set_s(t_s)
        rig.apply_actions(t_s)
        rig.send_sync(tick, t_s)
        rig.service_controller()
        waited = time.monotonic()
        self.answering = self.await_heartbeats(rig, tick, t_s) or (tick == 0 and self.await_contact(rig, t_s))
        if self.answering:
            self.heard = True
        else:
            rig.deadline_miss(tick)
            self.check_contact(rig, time.monotonic() - waited)
        rig.record_debug()
        substeps = round(self.period_s / self.physics_dt_s)
        for k in range(substeps):
            now = t_s + k * self.physics_dt_s
            rig.plant.step(now)
            self.clock.set_s(now + self.physics_dt_s)
            rig.serve_plant(now + self.physics_dt_s)
        rig.record_state()

    def await_contact(self, rig, t_s: float) -> bool:
        """A program the rig started (``rig.process``) may still be starting when SYNC(0) goes out, and a
        frame sent before it listens is lost to it: SYNC(0) again every ``RESYNC_S`` until its first
        heartbeat, for up to ``process.START_S`` (a program ticks once per SYNC counter, so repeats are harmless)."""
        if rig.controller is not None or getattr(rig, "process", None) is None:
            return False
        from wheelleg.hil.program import process  # noqa: PLC0415 (a started program only)

        end = time.monotonic() + process.START_S
        saved, self.deadline_s = self.deadline_s, RESYNC_S
        try:
            while time.monotonic() < end:
                rig.check_program()
                rig.repeat_sync(0, t_s)
                if self.await_heartbeats(rig, 0, t_s):
                    return True
        finally:
            self.deadline_s = saved
        return False

    def check_contact(self, rig, waited_s: float) -> None:
        """``NoController`` once an external controller has been silent ``CONTACT_S`` from the start."""
        if rig.controller is not None or self.heard:
            return
        self.silent_s += waited_s
        if self.silent_s >= CONTACT_S:
            if getattr(rig, "process", None) is not None:
                raise NoController(f"no heartbeat from the program in {self.silent_s:.1f} s: a command runs "
                                   "lockstep only when it answers SYNC with the heartbeat (e.g. --sync); "
                                   "free-running, run it with --realtime" + rig.program_output())
            raise NoController(f"no heartbeat from an external controller in {self.silent_s:.1f} s on "
                               f"{'/'.join(rig.names.values())}: is `wheelleg controller --sync` running there?")

    def heartbeats_in(self, tick: int) -> bool:
        return all(w.tick == tick for w in self.watches.values())

    def waited_out(self, rig, started: float) -> bool:
        """Whether a tick that began waiting at ``started`` (monotonic s) has waited long enough for
        its heartbeats: ``deadline_s`` for a silent program, ``patience_s`` for an answering one. Past
        ``deadline_s`` it asks whether a program the rig started has exited (``ProgramExited``): a
        dead program is not waited on."""
        waited = time.monotonic() - started
        if waited <= self.deadline_s:
            return False
        rig.check_program()
        return not self.answering or waited > self.patience_s

    def await_heartbeats(self, rig, tick: int, t_s: float) -> bool:
        started = time.monotonic()
        while True:
            rig.serve_plant(t_s)
            if self.heartbeats_in(tick):
                return True
            if rig.controller is not None or self.waited_out(rig, started):
                return False
            time.sleep(POLL_S)


class HeldLockstep(Lockstep):
    """Lockstep held on a real transport: frames gathered until both heartbeats are in."""

    def __init__(self, period_s: float, physics_dt_s: float, deadline_s: float, patience_s: float | None = None):
        super().__init__(period_s, physics_dt_s, deadline_s, patience_s)
        self.held: dict[str, HeldBus] = {}

    def bus_end(self, bus: str, end: can.BusABC):
        super().bus_end(bus, end)
        self.held[bus] = HeldBus(end)
        return self.held[bus]

    def await_heartbeats(self, rig, tick: int, t_s: float) -> bool:
        started = time.monotonic()
        while True:
            for bus, held in self.held.items():
                for msg in held.gather():
                    self.watches[bus].note(msg)
            done = self.heartbeats_in(tick)
            if done or self.waited_out(rig, started):
                break
            rig.service_controller()  # its SYNC may have been in flight
            time.sleep(POLL_S)
        rig.serve_plant(t_s)  # CAN1's held frames, then CAN2's: the virtual bus's order
        return done
