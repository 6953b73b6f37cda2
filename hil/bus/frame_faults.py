"""Frame faults on one rig bus: the machinery behind hil/run/faults.py's frame injectors.

``BusFaults`` is a stage of a plant-side ``wheelleg.hil.bus.plant_bus.PlantBus``
and applies the active ``FrameFault``s: to
frames the plant sends towards the controller (drop, delay, corrupt, error
frames, a babbling or garbage node, CAN arbitration) and to frames the
controller sent towards the devices (drop). The rig's lockstep frames (SYNC,
Heartbeat) are never touched.
"""
from __future__ import annotations

from dataclasses import dataclass
import can
import numpy as np

from wheelleg.controller import constants as C
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import CAN1, CAN2, load_bus
from wheelleg.hil.bus.busload import arbitration_priority, frame_bits, wire_ns

_RIG = load_bus(CAN1)
LOCKSTEP_IDS = frozenset(_RIG.get_message_by_name(n).frame_id for n in ("SYNC", "Heartbeat"))
TO_CONTROLLER, TO_DEVICES, BOTH = "to_controller", "to_devices", "both"
# SocketCAN error class: protocol violation, bus error (linux/can/error.h)
ERROR_FRAME_ID = 0x00000008 | 0x00000080


@dataclass(frozen=True)
class Select:
    """Which frames a frame fault touches: standard ``ids`` and/or CyberGear ``motors`` (None: all)."""

    ids: frozenset | None = None
    motors: frozenset | None = None

    def matches(self, msg: can.Message, towards_controller: bool) -> bool:
        if self.ids is None and self.motors is None:
            return True
        if msg.is_extended_id:
            # a reply carries the motor in bits 15..8, a request its target in bits 7..0
            motor = cg.reply_motor(msg.arbitration_id) if towards_controller else cg.target(msg.arbitration_id)
            return self.motors is not None and motor in self.motors
        return self.ids is not None and msg.arbitration_id in self.ids


def make_select(ids, motors) -> Select:
    return Select(None if ids is None else frozenset(ids), None if motors is None else frozenset(motors))


class FrameFault:
    """One active fault on a bus; subclasses override what they act on."""

    direction = TO_CONTROLLER

    def __init__(self, select: Select, rng: np.random.Generator):
        self.select, self.rng = select, rng
        self.count = 0  # frames it acted on

    def outbound(self, msg: can.Message, now_ns: int, bus: "BusFaults") -> list[can.Message]:
        return [msg]

    def inbound(self, msg: can.Message) -> bool:
        """False: the devices never get ``msg``."""
        return True

    def spontaneous(self, now_ns: int) -> list[can.Message]:
        """Frames the fault itself puts on the bus by ``now_ns`` (a babbling node)."""
        return []


class Drop(FrameFault):
    def __init__(self, select, rng, rate: float, direction: str):
        super().__init__(select, rng)
        if direction not in (TO_CONTROLLER, TO_DEVICES, BOTH):
            raise ValueError(f"direction must be {TO_CONTROLLER}, {TO_DEVICES} or {BOTH}, got {direction!r}")
        self.rate, self.direction = _rate(rate), direction

    def _drops(self) -> bool:
        if self.rng.random() < self.rate:
            self.count += 1
            return True
        return False

    def outbound(self, msg, now_ns, bus):
        return [] if self.direction != TO_DEVICES and self._drops() else [msg]

    def inbound(self, msg):
        return not (self.direction != TO_CONTROLLER and self._drops())


class BusOff(Drop):
    """Nothing crosses the bus either way (the controller's CAN peripheral is bus-off)."""

    def __init__(self, select, rng):
        super().__init__(select, rng, 1.0, BOTH)


class Delay(FrameFault):
    """Frames reach the controller ``delay_s`` + U(0, ``jitter_s``) late, in their order."""

    def __init__(self, select, rng, delay_s: float, jitter_s: float):
        super().__init__(select, rng)
        if delay_s < 0.0 or jitter_s < 0.0:
            raise ValueError(f"delay and jitter must be >= 0 s, got {delay_s!r}, {jitter_s!r}")
        self.delay_ns, self.jitter_ns = round(delay_s * 1e9), round(jitter_s * 1e9)

    def outbound(self, msg, now_ns, bus):
        late = self.delay_ns + (int(self.rng.integers(self.jitter_ns + 1)) if self.jitter_ns else 0)
        bus.hold(msg, now_ns + late)
        self.count += 1
        return []


class Corrupt(FrameFault):
    """With probability ``rate``: one data bit flipped ("bitflip") or the last byte lost ("truncate")."""

    def __init__(self, select, rng, rate: float, how: str):
        super().__init__(select, rng)
        if how not in ("bitflip", "truncate"):
            raise ValueError(f"corruption must be 'bitflip' or 'truncate', got {how!r}")
        self.rate, self.how = _rate(rate), how

    def outbound(self, msg, now_ns, bus):
        if not len(msg.data) or self.rng.random() >= self.rate:
            return [msg]
        self.count += 1
        data = bytearray(msg.data)
        if self.how == "truncate":
            data = data[:-1]
        else:
            bit = int(self.rng.integers(8 * len(data)))
            data[bit // 8] ^= 1 << (bit % 8)
        return [can.Message(arbitration_id=msg.arbitration_id, data=bytes(data), dlc=len(data),
                            is_extended_id=msg.is_extended_id, timestamp=msg.timestamp, check=False)]


class ErrorFrames(FrameFault):
    """After a frame, with probability ``rate``, an error frame (a receiver flagged a bit error)."""

    def __init__(self, select, rng, rate: float):
        super().__init__(select, rng)
        self.rate = _rate(rate)

    def outbound(self, msg, now_ns, bus):
        if self.rng.random() >= self.rate:
            return [msg]
        self.count += 1
        return [msg, can.Message(arbitration_id=ERROR_FRAME_ID, is_error_frame=True, data=bytes(8),
                                 timestamp=msg.timestamp, check=False)]


class Babble(FrameFault):
    """A node that floods the bus with ``frame_id`` frames worth ``load`` of its capacity."""

    def __init__(self, select, rng, load: float, frame_id: int, extended: bool, bitrate: int):
        super().__init__(select, rng)
        if not load > 0.0:
            raise ValueError(f"babble load must be > 0, got {load!r}")
        self.frame_id, self.extended = frame_id, extended
        self.data = bytes(8)
        self.period_ns = frame_bits(frame_id, extended, self.data) * 1e9 / bitrate / load
        self.next_ns: float | None = None

    def spontaneous(self, now_ns):
        if self.next_ns is None:
            self.next_ns = float(now_ns)
        out = []
        while self.next_ns <= now_ns:
            out.append(can.Message(arbitration_id=self.frame_id, data=self.data, is_extended_id=self.extended,
                                   timestamp=self.next_ns / 1e9, check=False))
            self.next_ns += self.period_ns
        self.count += len(out)
        return out


class Garbage(FrameFault):
    """A faulty node: frames of unknown ids, the robot's own ids with a wrong length, remote frames.

    Nothing it sends is a valid frame of the robot: the controller must count
    and ignore all of it. SYNC and Heartbeat ids are left out (the rig's).
    """

    def __init__(self, select, rng, bus: str, frames_per_s: float):
        super().__init__(select, rng)
        if not frames_per_s > 0.0:
            raise ValueError(f"frames_per_s must be > 0, got {frames_per_s!r}")
        self.period_ns = 1e9 / frames_per_s
        self.next_ns: float | None = None
        db = load_bus(bus)
        self.known = [(m.frame_id, m.is_extended_frame, m.length) for m in db.messages
                      if m.frame_id not in LOCKSTEP_IDS]
        if bus == CAN2:  # CyberGear feedback to our host, as the controller parses it
            self.known += [(cg.reply_id(cg.T_FEEDBACK, j.motor_id, C.CG_HOST_ID, 2), True, 8) for j in C.JOINTS]
        self._ids = {(fid, ext) for fid, ext, _ in self.known} | {(fid, False) for fid in LOCKSTEP_IDS}

    def spontaneous(self, now_ns):
        if self.next_ns is None:
            self.next_ns = float(now_ns)
        out = []
        while self.next_ns <= now_ns:
            out.append(self._frame(self.next_ns / 1e9))
            self.next_ns += self.period_ns
        self.count += len(out)
        return out

    def _frame(self, t_s: float) -> can.Message:
        rng = self.rng
        kind = int(rng.integers(3))
        if kind == 0:  # an id nobody on the robot uses
            ext = bool(rng.integers(2))
            while True:
                fid = int(rng.integers(1 << (29 if ext else 11)))
                if (fid, ext) not in self._ids and not (ext and cg.target(fid) in {j.motor_id for j in C.JOINTS}):
                    break
            return can.Message(arbitration_id=fid, is_extended_id=ext, timestamp=t_s, check=False,
                               data=rng.bytes(int(rng.integers(9))))
        fid, ext, length = self.known[int(rng.integers(len(self.known)))]
        if kind == 1:  # the robot's id, the wrong length
            size = int(rng.choice([n for n in range(9) if n != length]))
            return can.Message(arbitration_id=fid, is_extended_id=ext, data=rng.bytes(size), timestamp=t_s,
                               check=False)
        return can.Message(arbitration_id=fid, is_extended_id=ext, is_remote_frame=True, dlc=length,
                           timestamp=t_s, check=False)


class Arbitration(FrameFault):
    """Plant frames wait for the wire in CAN priority order; too old ones are dropped.

    The controller's frames reach the devices at once (in the rig they are on
    the virtual bus before the plant sees them), so they take the wire first,
    as their ids mostly win anyway (CyberGear types 1/3/4 under type-2
    replies, 0x200 under the C620 feedback). The plant's frames are then
    sent one at a time: whenever the wire is free, the highest-priority frame
    queued by then goes; one that waited more than ``max_wait_s`` is dropped,
    as a node's transmit timeout aborts it.
    """

    def __init__(self, select, rng, bitrate: int, max_wait_s: float):
        super().__init__(select, rng)
        if not max_wait_s > 0.0:
            raise ValueError(f"max_wait_s must be > 0, got {max_wait_s!r}")
        self.bitrate, self.max_wait_ns = bitrate, round(max_wait_s * 1e9)
        self.free_at_ns = 0
        self.pending: list = []  # (queued ns, seq, msg)
        self._seq = 0

    def occupy(self, msg: can.Message, now_ns: int) -> None:
        """A controller (or SYNC) frame takes the wire from ``now_ns``."""
        self.free_at_ns = max(self.free_at_ns, now_ns) + self._wire_ns(msg)

    def _wire_ns(self, msg: can.Message) -> int:
        return wire_ns(msg.arbitration_id, msg.is_extended_id, bytes(msg.data), self.bitrate)

    def admit(self, frames: list, now_ns: int) -> list[can.Message]:
        """Queue ``frames`` (each at its time stamp, at the latest ``now_ns``); those that won the wire by now."""
        for msg in frames:
            stamp = round(msg.timestamp * 1e9)
            self._seq += 1
            self.pending.append((stamp if 0 <= stamp <= now_ns else now_ns, self._seq, msg))
        return self.release(now_ns)

    def release(self, now_ns: int) -> list[can.Message]:
        """Run the wire up to ``now_ns``: the frames sent, in order; late ones are dropped."""
        sent = []
        while self.pending:
            t = max(self.free_at_ns, min(e[0] for e in self.pending))
            if t > now_ns:
                break
            best = min((e for e in self.pending if e[0] <= t), key=lambda e: (priority(e[2]), e[1]))
            self.pending.remove(best)
            if t - best[0] > self.max_wait_ns:
                self.count += 1  # aborted after waiting too long
                continue
            self.free_at_ns = t + self._wire_ns(best[2])
            sent.append(best[2])
        expired = [e for e in self.pending if now_ns - e[0] > self.max_wait_ns]
        self.count += len(expired)
        self.pending = [e for e in self.pending if now_ns - e[0] <= self.max_wait_ns]
        return sent

    def drain(self) -> list[can.Message]:
        """Everything still waiting, in priority order (the model is being switched off)."""
        waiting = [e[2] for e in sorted(self.pending, key=lambda e: (priority(e[2]), e[1]))]
        self.pending = []
        return waiting


def priority(msg: can.Message) -> int:
    """CAN arbitration order (smaller wins): ``busload.arbitration_priority`` of ``msg``."""
    return arbitration_priority(msg.arbitration_id, msg.is_extended_id, msg.is_remote_frame)


def _rate(rate: float) -> float:
    if not 0.0 <= rate <= 1.0:
        raise ValueError(f"rate must be a probability in [0, 1], got {rate!r}")
    return float(rate)


class BusFaults:
    """The frame faults active on one plant-side bus end: a ``wheelleg.hil.bus.plant_bus.BusStage``.

    Time is the run's simulated clock (``clock.now_ns``). Faults act in the
    order they started; the arbitration model, when on, comes last. Frames
    held back (delayed, or waiting for the wire) are released when the plant
    next puts a frame on that bus at or after their time: at the latest at
    the next SYNC, i.e. before the controller's next tick, which is when it
    matters in lockstep. The trace shows them at their release.
    """

    def __init__(self, clock):
        self.clock = clock  # wheelleg.hil.bus.plant_bus.SimClock
        self.faults: list[FrameFault] = []
        self.arbiter: Arbitration | None = None
        self._held: list = []  # (release ns, seq, msg), release times non-decreasing
        self._seq = 0

    def add(self, fault: FrameFault) -> None:
        if isinstance(fault, Arbitration):
            if self.arbiter is not None:
                raise ValueError("arbitration is already modelled on this bus")
            self.arbiter = fault
        else:
            self.faults.append(fault)

    def remove(self, fault: FrameFault) -> None:
        """End ``fault``; whatever it still held goes out at the next chance."""
        if fault is self.arbiter:
            self.arbiter = None
            for msg in fault.drain():
                self.hold(msg, self.clock.now_ns)
        else:
            self.faults.remove(fault)

    def hold(self, msg: can.Message, release_ns: int) -> None:
        last = self._held[-1][0] if self._held else 0
        self._seq += 1
        self._held.append((max(release_ns, last), self._seq, msg))  # FIFO: a node's frames stay in order

    def _released(self, now_ns: int) -> list[can.Message]:
        out = []
        while self._held and self._held[0][0] <= now_ns:
            release_ns, _, msg = self._held.pop(0)
            out.append(can.Message(arbitration_id=msg.arbitration_id, data=bytes(msg.data), dlc=msg.dlc,
                                   is_extended_id=msg.is_extended_id, is_error_frame=msg.is_error_frame,
                                   timestamp=release_ns / 1e9, check=False))
        return out

    def outbound(self, frames: list[can.Message]) -> list[can.Message]:
        """Frames that go on the wire, towards the controller, when the plant sends ``frames``."""
        if not self.faults and self.arbiter is None and not self._held:
            return frames  # no fault on this bus: the common case, kept cheap
        return [out for msg in frames for out in self._outbound(msg)]

    def _outbound(self, msg: can.Message) -> list[can.Message]:
        now = self.clock.now_ns
        frames = self._released(now) + [m for f in self.faults for m in f.spontaneous(now)]
        lockstep = _is_lockstep(msg)
        if not lockstep:  # only the new frame meets the faults: released ones already did
            fresh = [msg]
            for fault in self.faults:
                fresh = [g for f in fresh
                         for g in (fault.outbound(f, now, self) if fault.select.matches(f, True) else [f])]
            frames += fresh
        if self.arbiter is not None:
            frames = self.arbiter.admit(frames, now)
            if lockstep:
                self.arbiter.occupy(msg, now)
        return frames + [msg] if lockstep else frames

    def inbound(self, msg: can.Message) -> bool:
        """False swallows a frame the controller sent before any device gets it."""
        if not self.faults and self.arbiter is None:
            return True  # no fault on this bus
        if self.arbiter is not None:
            self.arbiter.occupy(msg, self.clock.now_ns)
        if not _is_lockstep(msg):
            for fault in self.faults:
                if fault.select.matches(msg, False) and not fault.inbound(msg):
                    return False
        return True


def _is_lockstep(msg: can.Message) -> bool:
    return msg.arbitration_id in LOCKSTEP_IDS and not msg.is_extended_id and not msg.is_error_frame
