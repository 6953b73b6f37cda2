"""CAN logs as can-utils writes them (``candump -L`` / ``candump -l``).

A frame line is ``(<sec>.<usec>) <interface> <frame>`` where ``<frame>`` is
can-utils' compact form (lib.c ``sprint_canframe``):

    123#DEADBEEF          standard id: 3 hex digits, data as upper-case hex bytes
    1F000001#0011         extended id: 8 hex digits
    123#R  123#R8         remote request, optional DLC
    123##1DEADBEEF        CAN FD: '##', one flags nibble (1 BRS, 2 ESI), data
    20000080#0000000000000000   error frame: CAN_ERR_FLAG (0x20000000) set, class in the id

candump's timestamp is ``%010llu.%06llu`` (older versions: ``%ld.%06ld``);
newer candump may add a direction token (``R``/``T``) after the frame. Lines
that do not start with ``(`` are not frames: canplayer skips them, and candump
itself writes ``DROPCOUNT: dropped <n> CAN frame(s) on '<if>' socket (total
drops <m>)`` into the log when the socket reports overruns (candump.c).

What the players accept (checked against their sources):
- canplayer (can-utils canplayer.c): skips every line whose first char is not
  '('; reads ``(%ld.%ld) %s %s``, so the fraction must have exactly 6 digits;
  the frame goes through lib.c ``parse_canframe`` (3 or 8 id digits, '#',
  'R', '##' + flags, '.' separators allowed).
- python-can's ``CanutilsLogReader`` / ``can.player``: splits each non-blank
  line on whitespace into 3 (or 4 with R/T) fields, reads the timestamp as a
  float and the id by its digit count. It does NOT skip comment or DROPCOUNT
  lines, and it turns a line into an error frame only if the id has both
  CAN_ERR_FLAG and CAN_ERR_BUSERROR (0x80) set.
So ``CandumpWriter`` writes frame lines only, always 6 fraction digits, and
error frames with class CAN_ERR_BUSERROR when the caller gives no class.
"""
from __future__ import annotations

import gzip
import operator
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Iterator

from wheelleg.hil import fast
from wheelleg.hil.record.frame import Frame

CAN_ERR_FLAG = 0x20000000
CAN_ERR_MASK = 0x1FFFFFFF
CAN_ERR_BUSERROR = 0x00000080  # python-can's reader needs this class bit to see an error frame
CAN_SFF_MASK = 0x7FF
CAN_EFF_MASK = 0x1FFFFFFF
CANFD_BRS, CANFD_ESI, CANFD_FDF = 0x01, 0x02, 0x04
CAN_MAX_DLEN, CANFD_MAX_DLEN = 8, 64
_NS_PER_S, _NS_PER_US = 1_000_000_000, 1_000
_STANDARD_LINE, _EXTENDED_LINE = "(%010d.%06d) %s %03X#%s\n", "(%010d.%06d) %s %08X#%s\n"  # what format_line gives

_TIMESTAMP = re.compile(r"\((\d+)\.(\d{1,9})\)")
_FRAME = re.compile(r"""
    (?P<id>[0-9A-Fa-f]{3}|[0-9A-Fa-f]{8})\#
    (?: (?P<rtr>[Rr])(?P<rtr_dlc>[0-8]?)
      | \#(?P<flags>[0-9A-Fa-f])(?P<fd_data>(?:\.?[0-9A-Fa-f]{2})*)
      | (?P<data>(?:\.?[0-9A-Fa-f]{2})*)(?:_(?P<len8_dlc>[9A-Fa-f]))?
    )""", re.X)
_DROPCOUNT = re.compile(r"dropped (\d+) CAN frames? on '([^']*)'(?: socket)?(?: \(total drops (\d+)\))?")


class LogFormatError(ValueError):
    """A line of a candump log that is neither a frame, a comment nor a DROPCOUNT line."""

    def __init__(self, path: str, line_no: int, line: str, reason: str):
        self.path, self.line_no, self.line, self.reason = path, line_no, line, reason
        super().__init__(f"{path}:{line_no}: {reason}: {line!r}")


@dataclass(frozen=True)
class DropNotice:
    """A DROPCOUNT line: ``dropped`` frames lost on ``channel`` before line ``line_no``."""

    line_no: int
    channel: str
    dropped: int
    total: int | None
    after_t_ns: int | None  # time of the last frame before the notice


# -- formatting ------------------------------------------------------------------------
def format_frame(arbitration_id: int, is_extended: bool, data: bytes, is_error: bool = False, *,
                 is_remote: bool = False, remote_dlc: int = 0, is_fd: bool = False,
                 fd_flags: int = 0) -> str:
    """can-utils' compact frame text (without separators), e.g. ``123#DEADBEEF``."""
    if is_error:
        ident = "%08X" % (CAN_ERR_FLAG | ((arbitration_id & CAN_ERR_MASK) or CAN_ERR_BUSERROR))
    elif is_extended:
        if not 0 <= arbitration_id <= CAN_EFF_MASK:
            raise ValueError(f"extended id 0x{arbitration_id:X} out of range 0..0x1FFFFFFF")
        ident = "%08X" % arbitration_id
    else:
        if not 0 <= arbitration_id <= CAN_SFF_MASK:
            raise ValueError(f"standard id 0x{arbitration_id:X} out of range 0..0x7FF")
        ident = "%03X" % arbitration_id
    if is_remote:
        if is_fd or not 0 <= remote_dlc <= CAN_MAX_DLEN:
            raise ValueError("a remote frame is classic CAN with a DLC of 0..8")
        return f"{ident}#R{remote_dlc}" if remote_dlc else f"{ident}#R"
    if is_fd:
        # flags: BRS 1, ESI 2, FDF 4; python-can reads the nibble as a decimal digit
        if len(data) > CANFD_MAX_DLEN or not 0 <= fd_flags <= 7:
            raise ValueError(f"CAN FD frame: {len(data)} bytes (max 64), flags {fd_flags} (0..7)")
        return f"{ident}##{fd_flags:X}{data.hex().upper()}"
    if len(data) > CAN_MAX_DLEN:
        raise ValueError(f"classic CAN frame with {len(data)} data bytes (max 8)")
    return f"{ident}#{data.hex().upper()}"


def format_timestamp(t_ns: int) -> str:
    """``(%010d.%06d)`` from integer nanoseconds, truncated to microseconds (exact, no float)."""
    t_ns = operator.index(t_ns)
    if t_ns < 0:
        raise ValueError(f"timestamp must be >= 0 ns, got {t_ns}")
    sec, ns = divmod(t_ns, _NS_PER_S)
    return "(%010d.%06d)" % (sec, ns // _NS_PER_US)


def format_line(frame: Frame, epoch_ns: int = 0) -> str:
    """``frame`` as a ``candump -L`` line without its newline: ``(sec.usec) channel frame``,
    its time shifted by ``epoch_ns`` (ns)."""
    return "%s %s %s" % (format_timestamp(frame.t_ns + epoch_ns), frame.channel, format_frame(
        frame.arbitration_id, frame.is_extended, frame.data, frame.is_error, is_remote=frame.is_remote,
        remote_dlc=frame.dlc if frame.is_remote else 0, is_fd=frame.is_fd, fd_flags=frame.fd_flags))


class CandumpWriter:
    """Writes a ``candump -L`` log that canplayer and python-can's can.player replay as is.

    ``path_or_file``: a path (opened and closed here) or a text file object.
    The same calls always give the same bytes. ``flush_interval_s`` bounds, in
    wall-clock time, what a killed process leaves unwritten. ``epoch_ns`` is
    added to every frame's time (ns since 1970 of the recording's time 0).
    """

    def __init__(self, path_or_file, flush_interval_s: float | None = 1.0, epoch_ns: int = 0):
        if hasattr(path_or_file, "write"):
            self._file: IO[str] = path_or_file
            self._owns_file = False
            self.path = getattr(path_or_file, "name", "<stream>")
        else:
            self.path = Path(path_or_file)
            self._file = open(self.path, "w", encoding="ascii", newline="\n", buffering=1 << 16)
            self._owns_file = True
        self._channels: set[str] = set()
        self.epoch_ns = operator.index(epoch_ns)
        self._flush_interval_s = flush_interval_s
        self._flush_at = time.monotonic() + flush_interval_s if flush_interval_s else float("inf")
        self.frames = 0
        compiled = fast.core()  # the plain frames' lines in C (``wheelleg.hil.fast``); the same text
        in_range = -(1 << 63) <= self.epoch_ns < 1 << 63  # C's 64-bit nanoseconds
        self._lines = compiled.candump_lines if compiled is not None and in_range else None

    def write(self, frame: Frame) -> None:
        """One frame line: ``(sec.usec) channel frame``."""
        if self._file is None:
            raise ValueError(f"{self.path}: log already closed")
        channel = frame.channel
        if channel not in self._channels:
            self._check_channel(channel)
        self._file.write(format_line(frame, self.epoch_ns) + "\n")
        self.frames += 1
        if time.monotonic() >= self._flush_at:
            self.flush()

    on_frame = write  # one frame, as a recorder sink would get it

    def on_frames(self, frames) -> None:
        """Frames in time order (a recorder sink, ``wheelleg.hil.bus.recorder.FrameSink``): the lines
        ``write`` gives, written at once; a classic data frame's line made in one ``%``."""
        if self._file is None:
            raise ValueError(f"{self.path}: log already closed")
        if self._lines is not None:
            self._on_frames_compiled(frames)
            return
        epoch, lines = self.epoch_ns, []
        try:
            for f in frames:
                channel, arbitration_id, t_ns = f.channel, f.arbitration_id, f.t_ns + epoch
                if channel not in self._channels:
                    self._check_channel(channel)
                if f.is_error or f.is_remote or f.is_fd or type(t_ns) is not int or t_ns < 0 \
                        or len(f.data) > CAN_MAX_DLEN \
                        or not 0 <= arbitration_id <= (CAN_EFF_MASK if f.is_extended else CAN_SFF_MASK):
                    lines.append(format_line(f, epoch) + "\n")  # the checks and the other forms
                else:
                    lines.append((_EXTENDED_LINE if f.is_extended else _STANDARD_LINE) % (
                        t_ns // _NS_PER_S, t_ns % _NS_PER_S // _NS_PER_US, channel, arbitration_id,
                        f.data.hex().upper()))
        finally:  # a bad frame raises after the lines before it are written
            self._file.write("".join(lines))
        self.frames += len(lines)
        if time.monotonic() >= self._flush_at:
            self.flush()

    def _on_frames_compiled(self, frames) -> None:
        """``on_frames`` with the plain frames' lines made in C; each other frame (a new channel, an
        error, remote or FD frame, a bad field) through ``write``'s checks and ``format_line``."""
        epoch, lines, at, n = self.epoch_ns, [], 0, len(frames)
        try:
            while at < n:
                text, stop = self._lines(frames, epoch, self._channels, at)
                lines.append(text)
                self.frames += stop - at
                if stop < n:
                    f = frames[stop]
                    if f.channel not in self._channels:
                        self._check_channel(f.channel)
                    lines.append(format_line(f, epoch) + "\n")
                    self.frames += 1
                at = stop + 1
        finally:  # a bad frame raises after the lines before it are written
            self._file.write("".join(lines))
        if time.monotonic() >= self._flush_at:
            self.flush()

    def _check_channel(self, channel: str) -> None:
        if not isinstance(channel, str) or not channel or any(c.isspace() for c in channel) \
                or not channel.isascii():
            raise ValueError(f"bad CAN interface name {channel!r}: need non-empty ASCII without spaces")
        self._channels.add(channel)

    def flush(self) -> None:
        if self._file is not None:
            self._file.flush()
        if self._flush_interval_s:
            self._flush_at = time.monotonic() + self._flush_interval_s

    def close(self) -> None:
        if self._file is None:
            return
        self._file.flush()
        if self._owns_file:
            self._file.close()
        self._file = None

    stop = close

    def __enter__(self) -> "CandumpWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# -- parsing --------------------------------------------------------------------------------
def parse_timestamp(text: str) -> int:
    """``(sec.frac)`` -> integer ns; the fraction is decimal (6 digits from candump)."""
    m = _TIMESTAMP.fullmatch(text)
    if m is None:
        raise ValueError("timestamp is not '(<seconds>.<fraction>)'")
    sec, frac = m.groups()
    return int(sec) * _NS_PER_S + int(frac.ljust(9, "0"))


def parse_frame(text: str) -> dict:
    """can-utils' compact frame text -> ``Frame`` fields (without time/channel)."""
    m = _FRAME.fullmatch(text)
    if m is None:
        raise ValueError("frame is not <3 or 8 hex digit id>#<data>|R[dlc]|#<flags><data>")
    digits = m["id"]
    value = int(digits, 16)
    is_error = len(digits) == 8 and bool(value & CAN_ERR_FLAG)
    if len(digits) == 8 and value & ~(CAN_ERR_FLAG | CAN_EFF_MASK):
        raise ValueError(f"id {digits}: bits 30/31 are not part of an identifier")
    if len(digits) == 3 and value > CAN_SFF_MASK:
        raise ValueError(f"standard id {digits} > 0x7FF")
    fields = dict(arbitration_id=value & CAN_EFF_MASK, is_extended=len(digits) == 8 and not is_error,
                  is_error=is_error)
    if m["rtr"]:
        return dict(fields, data=b"", dlc=int(m["rtr_dlc"] or 0), is_remote=True)
    if m["flags"] is not None:
        data = bytes.fromhex(m["fd_data"].replace(".", ""))
        if len(data) > CANFD_MAX_DLEN:
            raise ValueError(f"CAN FD frame with {len(data)} data bytes (max 64)")
        return dict(fields, data=data, dlc=len(data), is_fd=True, fd_flags=int(m["flags"], 16))
    data = bytes.fromhex(m["data"].replace(".", ""))
    if len(data) > CAN_MAX_DLEN:
        raise ValueError(f"classic CAN frame with {len(data)} data bytes (max 8; FD needs '##')")
    dlc = len(data)
    if m["len8_dlc"]:
        if dlc != CAN_MAX_DLEN:
            raise ValueError("a raw DLC suffix '_<9..F>' needs 8 data bytes")
        dlc = int(m["len8_dlc"], 16)
    return dict(fields, data=data, dlc=dlc)


@dataclass
class CandumpReader:
    """Iterates the frames of a candump log; counts what is not a frame as it goes.

    ``strict`` (default): a malformed line raises ``LogFormatError`` naming
    file:line. ``strict=False``: it is skipped and listed in ``skipped``.
    ``drops`` lists the DROPCOUNT notices, ``comments`` counts '#' lines.
    A malformed last line without its newline is what a writer killed
    mid-line leaves: it is left out either way and ``cut_off`` says so.
    """

    path: str | Path
    strict: bool = True
    drops: list[DropNotice] = field(default_factory=list)
    skipped: list[tuple[int, str]] = field(default_factory=list)  # (line number, reason)
    comments: int = 0
    frames: int = 0
    cut_off: bool = False  # the log ends in a partly written line (left out)

    @property
    def dropped_frames(self) -> int:
        """Frames the capturing socket reported lost (sum of DROPCOUNT notices)."""
        return sum(d.dropped for d in self.drops)

    def __iter__(self) -> Iterator[Frame]:
        last_t: int | None = None
        with open_log_text(self.path) as f:
            for line_no, line in enumerate(f, start=1):
                text = line.strip()
                if not text:
                    continue
                if text[0] == "#":
                    self.comments += 1
                    continue
                if text[0] != "(" and "DROPCOUNT" in text:
                    self._note_drop(line_no, text, last_t)
                    continue
                try:
                    frame = _parse_line(text, line_no)
                except ValueError as exc:
                    if not line.endswith("\n"):  # only the file's last line can lack it
                        self.cut_off = True
                        continue
                    self._malformed(line_no, text, str(exc))
                    continue
                last_t = frame.t_ns
                self.frames += 1
                yield frame

    def _note_drop(self, line_no: int, text: str, last_t: int | None) -> None:
        m = _DROPCOUNT.search(text)
        if m is None:  # a DROPCOUNT line in some other wording: count it, amount unknown
            self.drops.append(DropNotice(line_no, "", 0, None, last_t))
            return
        total = int(m[3]) if m[3] is not None else None
        self.drops.append(DropNotice(line_no, m[2], int(m[1]), total, last_t))

    def _malformed(self, line_no: int, text: str, reason: str) -> None:
        if self.strict:
            raise LogFormatError(str(self.path), line_no, text, reason)
        self.skipped.append((line_no, reason))


def _parse_line(text: str, line_no: int) -> Frame:
    if text[0] != "(":
        raise ValueError("not a frame line (frames start with '(')")
    parts = text.split()
    if len(parts) not in (3, 4):
        raise ValueError(f"expected '(time) interface frame [R|T]', got {len(parts)} fields")
    direction = parts[3] if len(parts) == 4 else ""
    if direction and direction.upper() not in ("R", "T"):
        raise ValueError(f"unknown direction {direction!r} (R or T)")
    return Frame(t_ns=parse_timestamp(parts[0]), channel=parts[1], direction=direction.upper(),
                    line_no=line_no, **parse_frame(parts[2]))


GZIP_MAGIC = b"\x1f\x8b"


def open_log_text(path):
    """A candump log as text; gzip-compressed logs (``candump -L | gzip``) are read as they are."""
    with open(path, "rb") as f:
        compressed = f.read(2) == GZIP_MAGIC
    if compressed:
        return gzip.open(path, "rt", encoding="utf-8", errors="replace", newline=None)
    return open(path, encoding="utf-8", errors="replace", newline=None)


def read_candump(path, strict: bool = True) -> CandumpReader:
    """Frames of a candump log, in file order (see ``CandumpReader``)."""
    return CandumpReader(path, strict)
