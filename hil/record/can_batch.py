"""``/can/<channel>`` records: the frames of one bus in one window of bus time as one CDR message.

One MCAP message per frame cost 16 bytes of message index (the offsets
Foxglove's indexed reader needs) and 31 of record head for a frame of ~8 bytes;
one message per bus and window (the trace writer's ``can_window_s``, 100 ms,
the windows of ``/bus/load``) holds the same frames as parallel arrays
(``schemas.CAN_FRAMES_MSG``, a ROS 2 message that Foxglove and
mcap-ros2-support decode). ``pack`` writes one, ``unpack`` reads it back into
the ``Frame`` records that were packed, bit for bit (time, id, flags, dlc,
payload).

Times are gaps: each frame's bus time after the previous frame's (the first:
after the message's log time, which is its time, so 0). The rig's frames come
in the same rhythm every control period, so the gaps repeat and compress well
(10 s of balance, /can/ of both buses with its index: 2.59 MB one message per
frame; 0.82 MB in 2 ms messages with offsets from the log time, 0.78 with gaps;
0.55 MB in 100 ms messages with gaps, 0.76 with offsets, which no longer repeat).

CDR (little endian, after the 4-byte encapsulation header; each sequence is
a uint32 count, then its elements aligned to their size from the body's start):
``gap_ns`` and ``id`` uint32[], then ``flags``, ``dlc``, ``length`` and ``data``
uint8[], each count aligned to 4.
"""
from __future__ import annotations

import struct
from functools import lru_cache
from itertools import accumulate

import numpy as np

from wheelleg.hil import fast
from wheelleg.hil.record.frame import Frame, FrameColumns
from wheelleg.hil.record.schemas import CDR_LE

EXTENDED, ERROR, REMOTE, FD = 1, 2, 4, 8  # flags bits; bits 4-6: the CAN FD flags (BRS, ESI)
_FD_SHIFT = 4
_COUNT = struct.Struct("<I")


MAX_GAP_NS = (1 << 32) - 1  # a frame after the one before it in its message (uint32 gaps)


@lru_cache(maxsize=256)
def _head(n: int) -> struct.Struct:
    """Encapsulation header, gap_ns (count, n uint32) and id (count, n uint32) of ``n`` frames."""
    return struct.Struct(f"<4sI{n}II{n}I")


def _pad4(size: int) -> bytes:
    return b"\0" * (-size % 4)


def pack(frames: list[Frame]) -> bytes:
    """One ``/can/`` record of ``frames`` (one bus, in time order, each at most ``MAX_GAP_NS`` after the one
    before); the message's log time is ``frames[0].t_ns``. ValueError for a time or id out of range.

    The rig's own frames (classic data frames) are packed in C where it is built
    (``wheelleg.hil.fast``), the rest here: the same bytes."""
    compiled = fast.core()
    if compiled is not None:
        record = compiled.pack_plain(frames)
        if record is not None:
            return record
    n = len(frames)
    times = [f.t_ns for f in frames]
    gaps = [0] + [b - a for a, b in zip(times, times[1:])]
    ids = [f.arbitration_id for f in frames]
    try:
        head = _head(n).pack(CDR_LE, n, *gaps, n, *ids)
    except struct.error as exc:
        raise ValueError(f"frame times {times} must not go back and each lie within {MAX_GAP_NS} ns of the one "
                         f"before, ids {ids} within 0..0x1FFFFFFF") from exc
    if any([f.is_error or f.is_remote or f.is_fd or f.fd_flags for f in frames]):
        flags = bytes([f.is_extended | f.is_error << 1 | f.is_remote << 2 | f.is_fd << 3 | f.fd_flags << _FD_SHIFT
                       for f in frames])
    else:  # the rig's frames: only the extended bit (half the time of the line above)
        flags = bytes([f.is_extended for f in frames])
    dlcs = bytes([f.dlc for f in frames])
    payloads = [f.data for f in frames]
    lengths = bytes([len(d) for d in payloads])
    data = b"".join(payloads)
    count = _COUNT.pack(n)
    parts = [head, count, flags]  # head ends 4-aligned (body offset 8 + 8 n)
    size = len(head) - 4 + 4 + n
    for column in (dlcs, lengths):
        pad = _pad4(size)
        parts += [pad, count, column]
        size += len(pad) + 4 + n
    parts += [_pad4(size), _COUNT.pack(len(data)), data]
    return b"".join(parts)


def _byte_columns(n: int) -> tuple[int, int, int, int]:
    """Where the flags, dlc and length columns (n bytes each) and the payloads of an ``n``-frame
    record start: each column after the head and its count, 4-aligned as ``pack`` lays them
    out (file offsets: the CDR body + 4)."""
    at = 4 + 8 + 8 * n + 4  # the flags: past the head and their count
    starts = [at]
    for _ in range(3):  # dlc, length, then the payloads' count
        at += n
        at += -(at - 4) % 4 + 4
        starts.append(at)
    return tuple(starts)


def unpack(record: bytes, log_time_ns: int, channel: str, bus: str = "") -> list[Frame]:
    """The frames of one ``/can/`` record logged at ``log_time_ns``, on ``channel`` with the role ``bus``."""
    if record[:4] != CDR_LE:
        raise ValueError(f"/can/{channel}: not a little-endian CDR record")
    (n,) = _COUNT.unpack_from(record, 4)
    values = _head(n).unpack_from(record)
    times, ids = list(accumulate(values[2:2 + n], initial=log_time_ns))[1:], values[3 + n:]
    flags_at, dlcs_at, lengths_at, data_at = _byte_columns(n)
    flags, dlcs, lengths = (record[at:at + n] for at in (flags_at, dlcs_at, lengths_at))
    out, start = [], data_at
    for t_ns, can_id, flag, dlc, size in zip(times, ids, flags, dlcs, lengths):
        out.append(Frame(t_ns, channel, can_id, bool(flag & EXTENDED), record[start:start + size], dlc, bus,
                         bool(flag & ERROR), bool(flag & REMOTE), bool(flag & FD), flag >> _FD_SHIFT))
        start += size
    return out


def unpack_columns(record: bytes, log_time_ns: int) -> FrameColumns:
    """The frames of one ``/can/`` record by column (what ``unpack`` gives, without a ``Frame`` each)."""
    if record[:4] != CDR_LE:
        raise ValueError("/can/: not a little-endian CDR record")
    (n,) = _COUNT.unpack_from(record, 4)
    gaps = np.frombuffer(record, dtype="<u4", count=n, offset=8)
    ids = np.frombuffer(record, dtype="<u4", count=n, offset=12 + 4 * n)
    flags_at, _, lengths_at, data_at = _byte_columns(n)
    flags = np.frombuffer(record, dtype=np.uint8, count=n, offset=flags_at)
    lengths = record[lengths_at:lengths_at + n]
    if len(flags) != n or len(lengths) != n:
        raise ValueError(f"/can/: a record of {n} frames is cut short")
    data, start = [], data_at
    for size in lengths:
        data.append(record[start:start + size])
        start += size
    return FrameColumns(log_time_ns + np.cumsum(gaps, dtype=np.int64), ids.astype(np.int64),
                        (flags & EXTENDED) != 0, (flags & ERROR) != 0, data)
