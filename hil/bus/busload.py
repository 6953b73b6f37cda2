"""Bus-load model: how long each frame holds a CAN bus, and the load per second.

A classic CAN data frame is SOF, arbitration field (11 or 29-bit id with SRR,
IDE, RTR), control field, data, CRC-15, then CRC delimiter, ACK slot and
delimiter, 7-bit EOF and 3-bit intermission. Bit stuffing (a complement bit
after five equal bits) applies from SOF to the end of the CRC; it is counted
exactly on the frame's own bits. ``arbitration_priority`` orders frames as
arbitration does. The order and times of the rig's frames on the wire:
``wheelleg.hil.bus.wire_order``.
"""
from __future__ import annotations

import functools

import numpy as np

from wheelleg.hil.record import schemas

TRAILER_BITS = 1 + 2 + 7 + 3  # CRC delimiter, ACK slot + delimiter, EOF, intermission
DEFAULT_BITRATE = 1_000_000  # bit/s


def _crc15_table() -> tuple:
    table = []
    for byte in range(256):
        crc = byte << 7
        for _ in range(8):
            crc = ((crc << 1) ^ 0x4599) if crc & 0x4000 else (crc << 1)
        table.append(crc & 0x7FFF)
    return tuple(table)


_CRC_TABLE = _crc15_table()


def crc15(value: int, nbits: int) -> int:
    """CAN's CRC-15 (polynomial 0x4599) of the ``nbits`` low bits of ``value``, MSB first.

    The register starts at 0 and zero bits shifted into a zero register leave
    it 0, so the bits are padded with leading zeros to whole bytes and go
    through the table a byte at a time.
    """
    crc = 0
    for byte in value.to_bytes((nbits + 7) // 8, "big"):
        crc = ((crc << 8) & 0x7FFF) ^ _CRC_TABLE[((crc >> 7) ^ byte) & 0xFF]
    return crc


def _stuff_step(last: int, run: int, bit: int) -> tuple[int, int, int]:
    """One bit through the stuffing rule: (last bit, run length, stuff bits added)."""
    run = run + 1 if bit == last else 1
    if run == 5:  # a complement bit goes in and starts the next run
        return 1 - bit, 1, 1
    return bit, run, 0


# The stuffing state between bits, (last bit -1/0/1, run length 0..4), as one
# small int so that the tables below are flat lists indexed by arithmetic.
_START = 0  # no bit yet: (last -1, run 0)


def _state(last: int, run: int) -> int:
    return (last + 1) * 5 + run


def _stuff_chunk(state: int, bits: int, width: int) -> int:
    """``width`` bits (MSB first) through the rule from ``state``: (new state << 4) | stuff bits added."""
    last, run = state // 5 - 1, state % 5
    added = 0
    for i in range(width - 1, -1, -1):
        last, run, n = _stuff_step(last, run, (bits >> i) & 1)
        added += n
    return (_state(last, run) << 4) | added


# every state x every byte: index (state << 8) | byte
_STUFF = [_stuff_chunk(state, byte, 8) for state in range(15) for byte in range(256)]
# the 0..7 bits before the first whole byte, from the start state: _STUFF_LEAD[width][bits]
_STUFF_LEAD = [[_stuff_chunk(_START, bits, width) for bits in range(1 << width)] for width in range(8)]


def stuff_bits(value: int, nbits: int) -> int:
    """Stuff bits a transmitter inserts into the ``nbits`` low bits of ``value``, MSB first.

    After five equal bits comes a complement bit, which itself counts towards
    the next run. The bits before the first whole byte go through one lookup,
    the rest a byte at a time through a precomputed table.
    """
    return _stuffed(value, nbits)[1]


def _stuffed(value: int, nbits: int) -> tuple[int, int]:
    """(stuffing state after the bits, stuff bits added) for the ``nbits`` low bits of ``value`` from the start."""
    lead = nbits % 8
    body = nbits - lead
    packed = _STUFF_LEAD[lead][value >> body]
    state, count = packed >> 4, packed & 15
    for byte in (value & ((1 << body) - 1)).to_bytes(body // 8, "big"):
        packed = _STUFF[(state << 8) | byte]
        state = packed >> 4
        count += packed & 15
    return state, count


# the CRC's low 7 bits from any state: index (state << 7) | bits
_STUFF_7 = [_stuff_chunk(state, bits, 7) for state in range(15) for bits in range(128)]


@functools.lru_cache(maxsize=4096)
def _header(arbitration_id: int, is_extended: bool, dlc: int, is_remote: bool) -> tuple[int, int, int, int]:
    """(bits, CRC register, stuffing state, stuff bits) of a frame's header: SOF to DLC.

    What the payload does not change, worked out once per identifier and length;
    ``frame_bits`` goes on from there a payload byte at a time.
    """
    if is_extended:  # SOF, base id, SRR, IDE, extension, RTR, r1, r0, DLC
        head = ((arbitration_id >> 18) << 27) | (0b11 << 25) | ((arbitration_id & 0x3FFFF) << 7) \
            | (int(is_remote) << 6) | dlc
        head_bits = 1 + 11 + 2 + 18 + 3 + 4
    else:  # SOF, id, RTR, IDE, r0, DLC
        head = (arbitration_id << 7) | (int(is_remote) << 6) | dlc
        head_bits = 1 + 11 + 3 + 4
    return (head_bits, crc15(head, head_bits), *_stuffed(head, head_bits))


# Not cached: a payload seldom repeats (feedback and commands carry the moment's values), so a
# cache by payload mostly missed (1.7 us a miss against 1.2 uncached), and once full its dict was
# rebuilt every few seconds: a 1.5-2 ms stall in the middle of a real-time step.
def frame_bits(arbitration_id: int, is_extended: bool, data: bytes, is_remote: bool = False) -> int:
    """Bits one classic CAN frame occupies on the wire, stuff bits included.

    The header's CRC register and stuffing state come from ``_header``; each
    payload byte then moves both through their tables (the CRC table works from
    any register, the stuffing table from any state), and the CRC's own 15
    bits are stuffed last.
    """
    nbits, crc, state, count = _header(arbitration_id, is_extended, len(data), is_remote)
    if not is_remote:
        crc_table, stuff_table = _CRC_TABLE, _STUFF
        for byte in data:
            crc = ((crc << 8) & 0x7FFF) ^ crc_table[((crc >> 7) ^ byte) & 0xFF]
            packed = stuff_table[(state << 8) | byte]
            state = packed >> 4
            count += packed & 15
        nbits += 8 * len(data)
    packed = _STUFF[(state << 8) | (crc >> 7)]
    count += (packed & 15) + (_STUFF_7[((packed >> 4) << 7) | (crc & 0x7F)] & 15)
    return nbits + 15 + count + TRAILER_BITS


def wire_ns(arbitration_id: int, is_extended: bool, data: bytes, bitrate: int) -> int:
    """Time (ns, floored) one classic frame holds a bus of ``bitrate`` bit/s."""
    return frame_bits(arbitration_id, is_extended, data) * 1_000_000_000 // bitrate


def max_frame_bits(is_extended, dlc) -> np.ndarray:
    """The most bits a classic data frame of each format can take, whatever its id and payload:
    ``is_extended`` (n,) bools, ``dlc`` (n,) payload lengths. Worst-case stuffing (a stuff bit
    after every four bits of SOF..CRC), so never below ``frame_bits``; for a bound where the
    exact figure costs a pass over every payload."""
    stuffable = np.where(np.asarray(is_extended, dtype=bool), 54, 34) + 8 * np.asarray(dlc, dtype=np.int64)
    return stuffable + (stuffable - 1) // 4 + TRAILER_BITS


BATCH_MIN = 64  # frames from which ``wire_ns_batch`` goes through numpy (below: ``frame_bits`` one by one)
_CRC_ARRAY = np.array(_CRC_TABLE, dtype=np.int64)
_STUFF_ARRAY = np.array(_STUFF, dtype=np.int64)
_STUFF_7_ARRAY = np.array(_STUFF_7, dtype=np.int64)


def wire_ns_batch(frames, bitrate: int) -> list[int]:
    """``wire_ns`` of each of ``frames`` (``Frame``s: id, extended, data), as a list.

    From ``BATCH_MIN`` frames on, one numpy pass: each frame's header
    (``_header``, once per identifier and length), then the payload bytes
    column by column through the CRC and stuffing tables for every frame at
    once (the bytes past a frame's length leave it as it is), then the CRC's
    own bits: ``frame_bits``' arithmetic, a third of its cost a frame.
    """
    n = len(frames)
    kinds = None
    if n >= BATCH_MIN:  # id, extended, length: what a header depends on
        try:
            kinds = np.fromiter([f.arbitration_id | (f.is_extended << 32) | (len(f.data) << 33) for f in frames],
                                dtype=np.int64, count=n)
        except OverflowError:
            pass
    if kinds is None or ((kinds & 0xFFFFFFFF) >> 29).any():  # few, or an id beyond 29 bits: one by one
        return [frame_bits(f.arbitration_id, f.is_extended, f.data) * 1_000_000_000 // bitrate for f in frames]
    unique, which = np.unique(kinds, return_inverse=True)
    heads = np.array([_header(k & 0x1FFFFFFF, bool(k >> 32 & 1), k >> 33, False) for k in unique.tolist()],
                     dtype=np.int64).reshape(-1, 4)[which]
    lengths = kinds >> 33
    nbits, crc, state, count = heads[:, 0] + 8 * lengths, heads[:, 1].copy(), heads[:, 2].copy(), heads[:, 3].copy()
    for column, byte in enumerate(_byte_columns([f.data for f in frames], lengths)):
        on = lengths > column
        stepped = ((crc << 8) & 0x7FFF) ^ _CRC_ARRAY[((crc >> 7) ^ byte) & 0xFF]
        packed = _STUFF_ARRAY[(state << 8) | byte]
        np.copyto(crc, stepped, where=on)
        np.copyto(state, packed >> 4, where=on)
        count += (packed & 15) * on
    packed = _STUFF_ARRAY[(state << 8) | (crc >> 7)]
    count += (packed & 15) + (_STUFF_7_ARRAY[((packed >> 4) << 7) | (crc & 0x7F)] & 15)
    bits = nbits + 15 + count + TRAILER_BITS
    return (bits * 1_000_000_000 // bitrate).tolist()


def _byte_columns(payloads: list[bytes], lengths: np.ndarray) -> np.ndarray:
    """The payloads as columns, shape (longest, n): byte i of every payload (0 past its end)."""
    width = int(lengths.max())
    columns = np.zeros((width, len(payloads)), dtype=np.int64)
    if width:
        flat = np.frombuffer(b"".join(payloads), dtype=np.uint8)
        starts = np.repeat(np.cumsum(lengths) - lengths, lengths)
        columns[np.arange(flat.size) - starts, np.repeat(np.arange(len(payloads)), lengths)] = flat
    return columns


def arbitration_priority(arbitration_id: int, is_extended: bool, is_remote: bool = False) -> int:
    """A frame's rank in CAN arbitration (smaller wins): the bits as they meet on the wire.

    The 11 base id bits first; then a standard frame's RTR bit meets an
    extended frame's SRR (always recessive) and the IDE bit, so a standard
    frame beats an extended one with the same base id; then the 18 extension
    bits; a data frame beats a remote frame with the same id.
    """
    if is_extended:
        return ((arbitration_id >> 18) << 21) | (1 << 20) | ((arbitration_id & 0x3FFFF) << 1) | int(is_remote)
    return (arbitration_id << 21) | int(is_remote)


LOAD_TOPIC = "/bus/load"


class LoadMeter:
    """Bus load per bus over fixed windows of simulated time, written to the trace.

    Every ``window_s`` it writes one ``/bus/load`` message per bus
    (``wheelleg.hil.record.schemas.BUS_LOAD``): the wire time the bus's frames took in the
    window (stuff bits included) over the window, i.e. busy seconds per
    second. Frames are charged when their sender queues them, so a demand
    beyond the bus's capacity shows as a load above 1 (without an
    arbitration fault nothing is dropped).
    """

    def __init__(self, wires: dict, trace=None, window_s: float = 0.1):
        if not window_s > 0.0:
            raise ValueError(f"window_s must be > 0, got {window_s!r}")
        self.wires, self.trace = wires, trace  # channel -> its wire_order.BusWire (busy_ns_total, frames_total)
        self.window_ns = round(window_s * 1e9)
        self._start_ns = 0
        self.due_ns = self.window_ns  # the clock time (ns) at which the open window closes
        self._busy = {}  # channel -> busy_ns_total at the window start
        self._frames = {}

    def sample(self, now_ns: int, final: bool = False) -> None:
        """Close the window if ``now_ns`` reached its end (or ``final`` and it is not empty)."""
        span = now_ns - self._start_ns
        if span < self.window_ns and not (final and span > 0):
            return
        for channel in sorted(self.wires):
            wire = self.wires[channel]
            busy = wire.busy_ns_total - self._busy.get(channel, 0)
            frames = wire.frames_total - self._frames.get(channel, 0)
            load = busy / span
            if self.trace is not None:
                self.trace.message(LOAD_TOPIC, now_ns, {
                    "channel": channel,
                    "window_start_s": self._start_ns / 1e9, "window_s": span / 1e9, "load": load,
                    "frames": frames, "frames_per_s": frames / (span / 1e9)}, "wheelleg.BusLoad", schemas.BUS_LOAD)
            self._busy[channel], self._frames[channel] = wire.busy_ns_total, wire.frames_total
        self._start_ns = now_ns
        self.due_ns = now_ns + self.window_ns
