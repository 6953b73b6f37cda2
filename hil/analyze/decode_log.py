"""Every frame of a recording decoded, the CyberGear id fields included: ``wheelleg decode``.

``decode(recording, ...)`` yields one ``DecodedFrame`` per frame in the
recording's order: the DBC message of its bus (``wheelleg.hil.record.decode.FrameDecoder``,
the trace's own decoder) and its values, the fields that live in a CyberGear
29-bit id first (communication type, host, target or motor id, the torque
feed-forward of a type-1 command, mode and fault bits of a type-2 reply), then
the payload's signals. ``format_text`` prints a frame the way ``cantools
decode`` does (the candump line, ``::``, the message and its signals with their
units and choice names); ``write_csv`` writes one row per frame.

Filters (all pure, no I/O): ``IdFilter`` (``parse_id_filter``: an id, an id
under a mask, or a CyberGear type and/or motor) and ``SignalSelection``
(``select_signals``: ``Signal`` or ``Message.Signal`` names, checked against the
DBC files and the id fields).
"""
from __future__ import annotations

import csv
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import IO

from wheelleg import dbc
from wheelleg.controller.constants import CG_HOST_ID
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.record.candump import CAN_EFF_MASK, CAN_SFF_MASK, format_line
from wheelleg.hil.record.decode import FrameDecoder
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.sources import DBS, ROLES, Recording

CSV_COLUMNS = ("time_s", "bus", "channel", "id", "message")
MAX_TYPE = cg.comm_type(CAN_EFF_MASK)  # every bit of the communication type set (31)
# choice names of the id fields (Mode of a reply), by field name: the CG_Id_* messages agree
ID_CHOICES = {s.name: {int(k): str(v) for k, v in s.choices.items()}
              for m in dbc.load_file(cg.ID_DBC).messages for s in m.signals if s.choices}


# -- which frames -------------------------------------------------------------------------------
@dataclass(frozen=True)
class IdFilter:
    """One ``--id``: an identifier under a mask, or CyberGear frames of a type and/or a motor."""

    can_id: int | None = None
    mask: int = CAN_EFF_MASK
    extended: bool = False
    ctype: int | None = None
    motor: int | None = None  # the motor a request goes to or a reply comes from

    def matches(self, frame: Frame) -> bool:
        if frame.is_error:
            return False
        if self.can_id is not None:
            return frame.is_extended == self.extended and frame.arbitration_id & self.mask == self.can_id & self.mask
        if not frame.is_extended:
            return False
        if self.ctype is not None and cg.comm_type(frame.arbitration_id) != self.ctype:
            return False
        return self.motor is None or cybergear_motor(frame.arbitration_id) == self.motor


def cybergear_motor(can_id: int) -> int:
    """The motor a CyberGear frame concerns: the sender of a reply, the target of a request."""
    return cg.reply_motor(can_id) if cg.from_motor(can_id, CG_HOST_ID) else cg.target(can_id)


def parse_id_filter(text: str) -> IdFilter:
    """``201``, ``0x0200FD01`` (an id, hex as candump writes it; 8 digits or > 0x7FF: extended),
    ``02000000:1F000000`` (candump's ID:MASK), ``type=2``, ``motor=1`` or ``type=2,motor=1``
    (CyberGear, decimal or 0x hex). ValueError with one line saying what is wrong."""
    spec = text.strip()
    if "=" in spec:
        return _cybergear_filter(spec)
    ident, sep, mask = spec.partition(":")
    can_id = _hex(ident, spec)
    digits = ident.strip().lower().removeprefix("0x")
    extended = len(digits) > 3 or can_id > CAN_SFF_MASK
    if can_id > CAN_EFF_MASK:
        raise ValueError(f"--id {text!r}: 0x{can_id:X} is beyond the 29-bit range")
    return IdFilter(can_id, _hex(mask, spec) if sep else (CAN_EFF_MASK if extended else CAN_SFF_MASK), extended)


def _hex(digits: str, spec: str) -> int:
    try:
        value = int(digits.strip(), 16)
    except ValueError:
        raise ValueError(f"--id {spec!r}: {digits.strip()!r} is not a hex identifier (e.g. 201, 0200FD01, "
                         "02000000:1F000000, type=2, motor=1)") from None
    if value < 0:
        raise ValueError(f"--id {spec!r}: a negative identifier")
    return value


def _cybergear_filter(spec: str) -> IdFilter:
    fields: dict[str, int] = {}
    for part in spec.split(","):
        key, _, value = (p.strip() for p in part.partition("="))
        if key not in ("type", "motor") or key in fields:
            raise ValueError(f"--id {spec!r}: expected type=N and/or motor=N, got {part.strip()!r}")
        try:
            fields[key] = int(value, 0)
        except ValueError:
            raise ValueError(f"--id {spec!r}: {key} {value!r} is not a number") from None
        limit = MAX_TYPE if key == "type" else 0xFF
        if not 0 <= fields[key] <= limit:
            raise ValueError(f"--id {spec!r}: {key} must be 0..{limit}")
    return IdFilter(ctype=fields.get("type"), motor=fields.get("motor"))


@dataclass(frozen=True)
class SignalSelection:
    """``--signal`` names: ``Signal`` (in any message) or ``Message.Signal``, in the order given."""

    names: tuple[str, ...] = ()

    def pick(self, message: str, values: dict) -> dict:
        """The selected values of one decoded frame, keyed by the name as given (all when none given)."""
        if not self.names:
            return values
        out = {}
        for name in self.names:
            msg, dot, signal = name.rpartition(".")
            if (not dot or msg == message) and signal in values:
                out[name] = values[signal]
        return out


def select_signals(names: Iterable[str] | None) -> SignalSelection:
    """The selection, every name checked against the DBC files and the CyberGear id fields."""
    names = tuple(n.strip() for n in names or ())
    known = FrameDecoder({role: DBS[role] for role in ROLES}).fields()
    bare = {signal for _, signal in known}
    for name in names:
        msg, dot, signal = name.rpartition(".")
        if (msg, signal) not in known if dot else signal not in bare:
            raise ValueError(f"--signal {name!r}: no such signal in the rig's DBC files or the CyberGear id "
                             "fields (give SIGNAL or MESSAGE.SIGNAL, e.g. TorqueRef, CG_Feedback.Pos)")
    return SignalSelection(names)


# -- decoding ----------------------------------------------------------------------------------
@dataclass
class DecodedFrame:
    """One frame and what its bus's DBC makes of it.

    ``message`` None: no message of the bus fits the id. ``problem``: why a fitting
    message did not decode (e.g. the length). ``values``: id fields first, then the
    payload (choices as numbers); ``units`` and ``choices`` describe them by name.
    """

    frame: Frame
    message: str | None = None
    values: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    choices: dict = field(default_factory=dict)
    problem: str = ""


class _Describer:
    """Units and choices of every value of a decode plan, worked out once per plan."""

    def __init__(self):
        self._by_plan: dict = {}

    def __call__(self, plan) -> tuple[dict, dict, tuple[str, ...]]:
        known = self._by_plan.get(plan)
        if known is None:
            units = {s.name: s.unit or "" for s in plan.message.signals}
            choices = {s.name: {int(k): str(v) for k, v in s.choices.items()}
                       for s in plan.message.signals if s.choices}
            id_names = tuple(name for name, _ in plan.id_units)
            units.update(plan.id_units)
            choices.update({name: ID_CHOICES[name] for name in id_names if name in ID_CHOICES})
            known = self._by_plan[plan] = (units, choices, id_names)
        return known


def decode(recording: Recording, filters: Iterable[IdFilter] = (),
           signals: SignalSelection = SignalSelection()) -> Iterator[DecodedFrame]:
    """The recording's frames decoded, in its order; only those ``filters`` let through (any of
    them; all frames when none) and, with ``signals``, that carry a selected signal."""
    filters = tuple(filters)
    decoder = FrameDecoder({name: DBS[role] for role, name in recording.channels.items()})
    describe = _Describer()
    for frame in recording.frames:
        if filters and not any(f.matches(frame) for f in filters):
            continue
        decoded = _decode_one(decoder, describe, frame)
        if signals.names:
            decoded.values = signals.pick(decoded.message or "", decoded.values)
            if not decoded.values:
                continue
        yield decoded


def _decode_one(decoder: FrameDecoder, describe: _Describer, frame: Frame) -> DecodedFrame:
    if frame.is_error:
        return DecodedFrame(frame, problem="error frame")
    plan = decoder.plan(frame.channel, frame.arbitration_id, frame.is_extended)
    if plan is None:
        return DecodedFrame(frame)
    if frame.is_remote:
        return DecodedFrame(frame, plan.name, problem="remote request")
    values = plan.decode(frame.arbitration_id, frame.data)
    if values is None:
        return DecodedFrame(frame, plan.name, problem=f"cannot decode {len(frame.data)} byte(s) "
                                                      f"(the DBC says {plan.message.length})")
    units, choices, id_names = describe(plan)
    ordered = {name: values[name] for name in id_names if name in values}
    ordered.update((k, v) for k, v in values.items() if k not in ordered)
    return DecodedFrame(frame, plan.name, ordered, units, choices)


# -- output ------------------------------------------------------------------------------------
def format_text(decoded: DecodedFrame, single_line: bool = False) -> str:
    """``cantools decode``'s text: ``LINE :: Message(\\n    Signal: value unit,\\n...\\n)``."""
    head = f"{format_line(decoded.frame)} ::"
    f = decoded.frame
    if decoded.message is None:
        return f"{head} {decoded.problem or f'Unknown frame id {f.arbitration_id} (0x{f.arbitration_id:x})'}"
    if decoded.problem:
        return f"{head} {decoded.message}: {decoded.problem}"
    parts = [_format_value(decoded, name, value) for name, value in decoded.values.items()]
    if single_line:
        return f"{head} {decoded.message}({', '.join(parts)})"
    body = ",\n".join("    " + p for p in parts)
    return f"{head}\n{decoded.message}(\n{body}\n)"


def _format_value(decoded: DecodedFrame, name: str, value) -> str:
    signal = name.rpartition(".")[2]
    label = decoded.choices.get(signal, {}).get(value) if isinstance(value, int) else None
    if label is not None:
        return f"{name}: {label}"
    unit = decoded.units.get(signal, "")
    return f"{name}: {value} {unit}" if unit else f"{name}: {value}"


def write_csv(frames: Iterable[DecodedFrame], out: IO[str], signals: SignalSelection = SignalSelection()) -> int:
    """One row per frame: time (s), bus role, interface, id, message, then the selected signals
    (all the frames carry, in order of first appearance, when none are selected). Returns the rows."""
    frames = list(frames)
    columns = list(signals.names)
    if not columns:
        seen = dict.fromkeys(name for d in frames for name in d.values)
        columns = list(seen)
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow([*CSV_COLUMNS, *columns])
    for d in frames:
        f = d.frame
        ident = f"0x{f.arbitration_id:08X}" if f.is_extended else f"0x{f.arbitration_id:03X}"
        writer.writerow([f"{f.t_ns / 1e9:.6f}", f.bus, f.channel, ident, d.message or d.problem,
                         *(d.values.get(name, "") for name in columns)])
    return len(frames)
