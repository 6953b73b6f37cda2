"""Bus-load model: how long each frame holds a CAN bus, and the load per second.

A classic CAN data frame is SOF, arbitration field (11 or 29-bit id with SRR,
IDE, RTR), control field, data, CRC-15, then CRC delimiter, ACK slot and
delimiter, 7-bit EOF and 3-bit intermission. Bit stuffing (a complement bit
after five equal bits) applies from SOF to the end of the CRC; it is counted
exactly on the frame's own bits. ``BusClock`` serialises the frames the rig
puts on one bus: a frame starts when the bus is free and its time stamp is
the end of its transmission, as a receiver sees it.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field

TRAILER_BITS = 1 + 2 + 7 + 3  # CRC delimiter, ACK slot + delimiter, EOF, intermission
DEFAULT_BITRATE = 1_000_000  # bit/s


def _crc15(bits: list[int]) -> int:
    crc = 0
    for bit in bits:
        nxt = bit ^ ((crc >> 14) & 1)
        crc = (crc << 1) & 0x7FFF
        if nxt:
            crc ^= 0x4599
    return crc


def _bits(value: int, width: int) -> list[int]:
    return [(value >> (width - 1 - i)) & 1 for i in range(width)]


def _stuff_count(bits: list[int]) -> int:
    count, run, last = 0, 0, None
    for bit in bits:
        if bit == last:
            run += 1
        else:
            run, last = 1, bit
        if run == 5:
            count += 1
            last, run = 1 - bit, 1  # the stuff bit starts a new run
    return count


@functools.lru_cache(maxsize=65536)
def frame_bits(arbitration_id: int, is_extended: bool, data: bytes, is_remote: bool = False) -> int:
    """Bits one classic CAN frame occupies on the wire, stuff bits included."""
    dlc = len(data)
    if is_extended:
        head = ([0] + _bits(arbitration_id >> 18, 11) + [1, 1] + _bits(arbitration_id & 0x3FFFF, 18)
                + [int(is_remote), 0, 0])
    else:
        head = [0] + _bits(arbitration_id, 11) + [int(is_remote), 0, 0]
    body = head + _bits(dlc, 4) + ([] if is_remote else [b for byte in data for b in _bits(byte, 8)])
    stuffed = body + _bits(_crc15(body), 15)
    return len(stuffed) + _stuff_count(stuffed) + TRAILER_BITS


@dataclass
class BusClock:
    """One bus's wire time: serialises frames and accumulates load."""

    bitrate: int = DEFAULT_BITRATE
    free_at_ns: int = 0  # when the bus is idle again
    busy_ns_window: int = 0  # wire time used in the current 1 s window
    window_start_ns: int = 0
    history: list = field(default_factory=list)  # (window start ns, load fraction)

    def transmit(self, now_ns: int, arbitration_id: int, is_extended: bool, data: bytes) -> int:
        """Put one frame on the wire no earlier than ``now_ns``; returns its end time (ns)."""
        self._roll_window(now_ns)
        duration = frame_bits(arbitration_id, is_extended, bytes(data)) * 1_000_000_000 // self.bitrate
        start = max(now_ns, self.free_at_ns)
        self.free_at_ns = start + duration
        self.busy_ns_window += duration
        return self.free_at_ns

    def _roll_window(self, now_ns: int) -> None:
        while now_ns >= self.window_start_ns + 1_000_000_000:
            self.history.append((self.window_start_ns, self.busy_ns_window / 1e9))
            self.window_start_ns += 1_000_000_000
            self.busy_ns_window = 0

    def load_so_far(self, now_ns: int) -> float:
        """Fraction of wire time used in the current window up to ``now_ns``."""
        span = max(now_ns - self.window_start_ns, 1)
        return min(self.busy_ns_window / span, 10.0)
