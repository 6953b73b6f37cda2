"""Decode raw frames into DBC signals for the trace's ``/decoded/...`` channels.

A frame is looked up in its bus's cantools database by identifier. CyberGear
frames carry fields in their 29-bit identifier and their payload layout sits
in cybergear.dbc at a canonical id (the communication type alone), so an
extended frame whose canonical id names a CyberGear message is decoded at that
id, and the id-resident fields (type, host, target or motor id, torque
feed-forward, mode, fault bits) are added through ``wheelleg.dbc.cybergear``.

Values are numbers (choices stay numbers). A frame that cannot be decoded
(unknown id, wrong length) yields ``None``: the raw frame is still recorded.
A type-0 request carries no payload (the official debugger sends DLC 1, ``00``;
other drivers DLC 0 or 8): it decodes to its id fields alone, whatever its length.

Speed: cantools' ``Message.decode`` costs 3-5 us per frame here, too much for
the rig's hot path; payloads of the message's length go through the compiled
codec (``wheelleg.dbc.codec``, checked against cantools in tests/test_dbc.py),
others (and layouts the codec does not compile) through cantools. Lookups are
cached per (channel, id) and the CyberGear id fields per id. The trace writer
decodes each message's frames in batches (``DecodePlan.decode_many``): one
numpy pass over the payloads per signal, the same dicts as ``decode`` gives.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from cantools.database.errors import DecodeError

from wheelleg import dbc
from wheelleg.controller.constants import CG_HOST_ID
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc.codec import MessageCodec

_CACHE_LIMIT = 65536  # distinct (channel, id, extended) keys remembered
_ID_CACHE_LIMIT = 4096  # CyberGear ids whose fields are remembered (type-1 ids vary with torque)
_TORQUE_UNIT = dbc.load_file(cg.ID_DBC).get_message_by_name("CG_Id_Motion") \
    .get_signal_by_name("TorqueRef").unit or ""
# The communication type's bits, read from the DBC once: the per-frame lookup
# shifts inline instead of calling cg.comm_type (3 calls, ~0.4 us).
_TYPE_SIGNAL = dbc.load_file(cg.ID_DBC).get_message_by_name("CG_Id_Request").get_signal_by_name("Type")
_TYPE_SHIFT, _TYPE_MASK = _TYPE_SIGNAL.start, (1 << _TYPE_SIGNAL.length) - 1


# -- CyberGear identifier fields -------------------------------------------------
def _request_fields(can_id: int) -> dict:
    return {"Type": cg.comm_type(can_id), "Host": cg.request_host(can_id), "Target": cg.target(can_id)}


def _motion_fields(can_id: int) -> dict:
    return {"Type": cg.T_MOTION, "Target": cg.target(can_id), "TorqueRef": cg.motion_torque(can_id)}


def _set_id_fields(can_id: int) -> dict:
    fields = _request_fields(can_id)
    fields["NewId"] = cg.set_id_new_id(can_id)
    return fields


def _reply_fields(can_id: int) -> dict:
    reply = cg.parse_reply_id(can_id)
    fields = {"Type": reply.ctype, "MotorId": reply.motor_id, "Host": reply.host}
    if reply.ctype == cg.T_FEEDBACK:
        fields["Mode"] = reply.mode
        for name in cg.FAULT_NAMES:
            fields[name] = int(name in reply.faults)
    return fields


def _either_fields(can_id: int) -> dict:
    """Types 0, 17, 21 are both requests and replies: ``cg.from_motor`` tells which."""
    if cg.from_motor(can_id, CG_HOST_ID):
        return _reply_fields(can_id)
    return _request_fields(can_id)


_BASE = {"Type": "", "Host": "", "Target": ""}
_ID_LAYOUTS: dict[int, tuple[Callable[[int], dict], dict[str, str]]] = {
    cg.T_MOTION: (_motion_fields, {"Type": "", "Target": "", "TorqueRef": _TORQUE_UNIT}),
    cg.T_FEEDBACK: (_reply_fields, {"Type": "", "MotorId": "", "Host": "", "Mode": "",
                                    **{name: "" for name in cg.FAULT_NAMES}}),
    cg.T_SET_ID: (_set_id_fields, {**_BASE, "NewId": ""}),
    cg.T_DEVICE_ID: (_either_fields, {**_BASE, "MotorId": ""}),
    cg.T_PARAM_READ: (_either_fields, {**_BASE, "MotorId": ""}),
    cg.T_FAULT_WARN: (_either_fields, {**_BASE, "MotorId": ""}),
}
_REQUEST_LAYOUT = (_request_fields, dict(_BASE))


def _cybergear_names() -> frozenset[str]:
    names = set()
    for file in dbc.CYBERGEAR_FILES.values():
        for message in dbc.load_file(file).messages:
            if message.is_extended_frame and cg.canonical_id(message.frame_id) == message.frame_id:
                names.add(message.name)
    return frozenset(names)


_CYBERGEAR_MESSAGES = _cybergear_names()


# -- plans ---------------------------------------------------------------------------
class DecodePlan:
    """How to decode frames of one identifier: the DBC message and the id fields."""

    __slots__ = ("message", "name", "codec", "id_fields", "id_units", "renamed", "bare_requests", "_id_cache",
                 "_columns", "vectorised")

    def __init__(self, message, id_fields: Callable[[int], dict] | None = None,
                 id_units: tuple[tuple[str, str], ...] = (), renamed: tuple[tuple[str, str], ...] = (),
                 bare_requests: bool = False):
        self.message = message  # cantools Message
        self.name: str = message.name
        self.codec = _compiled(message)
        self.id_fields = id_fields
        self.id_units = id_units  # (field name, unit) for the schema
        self.renamed = renamed  # id field -> name used (the payload wins a clash)
        self.bare_requests = bare_requests  # requests carry no payload: id fields only
        self._id_cache: dict[int, dict] = {}
        self._columns = _column_reader(self.codec) if not bare_requests else None
        self.vectorised = self._columns is not None  # decode_many takes the numpy path

    def decode(self, can_id: int, data: bytes) -> dict | None:
        if self.bare_requests and not cg.from_motor(can_id, CG_HOST_ID):
            return dict(self._fields_of(can_id))
        codec = self.codec
        try:
            if codec is not None and len(data) == codec.length:
                values = codec.decode(data)
            else:
                values = self.message.decode(data, decode_choices=False)
        except (DecodeError, ValueError, KeyError, IndexError):
            return None
        if self.id_fields is not None:
            values.update(self._fields_of(can_id))
        return values

    def decode_many(self, can_ids: list[int], payloads: list[bytes]) -> list[dict | None]:
        """``decode`` of each frame (the same dicts); one numpy pass when every payload has the codec's length."""
        batch = self.decode_columns(can_ids, payloads)
        if batch is None:
            return [self.decode(i, d) for i, d in zip(can_ids, payloads)]
        names, columns, id_fields = batch
        rows = [dict(zip(names, values)) for values in zip(*columns)] if names else [{} for _ in payloads]
        if id_fields is not None:
            for row, fields in zip(rows, id_fields):
                row.update(fields)
        return rows

    def decode_columns(self, can_ids: list[int], payloads: list[bytes]):
        """What ``decode`` gives each frame, by column: (signal names, one list of values per signal,
        each frame's id-field dict or None when the message has none), or None when the batch is not
        for the numpy path (too few frames, a payload of another length, a layout it cannot read).

        The id-field dicts are shared between frames of one id: read, do not change them.
        """
        length = self.codec.length if self._columns is not None else -1
        if len(payloads) < _MIN_BATCH or any(len(d) != length for d in payloads):
            return None
        names, columns = self._columns(payloads)
        id_fields = None if self.id_fields is None else [self._fields_of(i) for i in can_ids]
        return names, columns, id_fields

    def _fields_of(self, can_id: int) -> dict:
        fields = self._id_cache.get(can_id)
        if fields is None:
            fields = self.id_fields(can_id)
            for old, new in self.renamed:
                if old in fields:
                    fields[new] = fields.pop(old)
            if len(self._id_cache) < _ID_CACHE_LIMIT:
                self._id_cache[can_id] = fields
        return fields


_MIN_BATCH = 8  # fewer frames: decoded one by one (numpy's per-call cost would outweigh it)


def _column_reader(codec: MessageCodec | None):
    """``payloads -> (signal names, one list of values per signal)`` for ``codec``, or None where it cannot.

    Numpy over all payloads (each exactly ``codec.length`` bytes): the payload
    as a little- and a big-endian 64-bit word, each signal shifted and masked
    out, sign-extended, an IEEE float reinterpreted, then ``raw * scale +
    offset`` in the same order and types as the compiled codec (ints stay
    ints where cantools keeps them), so ``tolist`` gives the same numbers.
    Not for multiplexed messages, payloads over 8 bytes or fields over 62 bits.
    """
    if codec is None or codec.branches or codec.length > 8 \
            or any(f.float_format is None and f.mask.bit_length() > 62 for f in codec.fields):
        return None
    length, fields = codec.length, codec.fields
    names = [f.name for f in fields]
    orders = sorted({f.big for f in fields})

    def columns(payloads: list[bytes]) -> tuple[list[str], list[list]]:
        raw = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(len(payloads), length)
        words = {}
        for big in orders:
            padded = np.zeros((len(payloads), 8), dtype=np.uint8)
            if big:
                padded[:, 8 - length:] = raw
            else:
                padded[:, :length] = raw
            words[big] = padded.view(">u8" if big else "<u8")[:, 0]
        return names, [_signal_values(f, words[f.big]).tolist() for f in fields]

    return columns


def _signal_values(field, words: np.ndarray) -> np.ndarray:
    """One signal's physical values from the payload words (uint64, shape (n,)), typed as the codec types them."""
    raw = (words >> np.uint64(field.shift)) & np.uint64(field.mask)
    if field.float_format == "f":
        values = raw.astype(np.uint32).view(np.float32).astype(np.float64)
    elif field.float_format == "d":
        values = raw.view(np.float64)
    else:
        values = raw.astype(np.int64)
        if field.sign:
            values = values - ((values & field.sign) != 0) * (field.sign << 1)
    if field.conv_scale is not None:
        values = values * field.conv_scale + field.conv_offset
    return values


def _compiled(message) -> MessageCodec | None:
    """The compiled codec of ``message``, or None where only cantools decodes it (nested multiplexing)."""
    try:
        return MessageCodec.of(message)
    except ValueError:
        return None


def _cybergear_plan(message) -> DecodePlan:
    fn, units = _ID_LAYOUTS.get(cg.comm_type(message.frame_id), _REQUEST_LAYOUT)
    payload = {s.name for s in message.signals}
    renamed = tuple((name, "Id" + name) for name in units if name in payload)
    rename = dict(renamed)
    return DecodePlan(message, fn, tuple((rename.get(k, k), u) for k, u in units.items()), renamed,
                      bare_requests=cg.comm_type(message.frame_id) == cg.T_DEVICE_ID)


class FrameDecoder:
    """Decodes frames of the channels in ``dbs`` (channel name -> cantools Database).

    There is one ``DecodePlan`` object per (channel, message), so callers may
    key their own per-topic state on the plan object itself.
    """

    def __init__(self, dbs: dict):
        self._dbs = dict(dbs)
        self._plans: dict[tuple, DecodePlan | None] = {}
        self._unique: dict[tuple[str, str], DecodePlan] = {}  # one plan per (channel, message)
        # channel -> communication type -> plan, for extended CyberGear ids
        self._cybergear: dict[str, dict[int, DecodePlan]] = {}
        for channel, db in self._dbs.items():
            by_type = {cg.comm_type(m.frame_id): _cybergear_plan(m) for m in db.messages
                       if m.is_extended_frame and m.name in _CYBERGEAR_MESSAGES}
            if by_type:
                self._cybergear[channel] = by_type

    @property
    def channels(self) -> list[str]:
        return list(self._dbs)

    def fields(self) -> set[tuple[str, str]]:
        """(message, field) for every value a decoded frame can carry: DBC signals and CyberGear id fields."""
        out = {(m.name, s.name) for db in self._dbs.values() for m in db.messages for s in m.signals}
        for by_type in self._cybergear.values():
            out |= {(plan.name, name) for plan in by_type.values() for name, _ in plan.id_units}
        return out

    def plan(self, channel: str, can_id: int, is_extended: bool) -> DecodePlan | None:
        """The decode plan of one identifier on ``channel``, or None if no DBC message fits."""
        if is_extended:
            by_type = self._cybergear.get(channel)
            if by_type is not None:
                plan = by_type.get((can_id >> _TYPE_SHIFT) & _TYPE_MASK)
                if plan is not None:
                    return plan
        key = (channel, can_id, is_extended)
        plan = self._plans.get(key, False)
        if plan is False:
            plan = self._lookup(channel, can_id, is_extended)
            if len(self._plans) < _CACHE_LIMIT:
                self._plans[key] = plan
        return plan

    def _lookup(self, channel: str, can_id: int, is_extended: bool) -> DecodePlan | None:
        db = self._dbs.get(channel)
        if db is None:
            return None
        try:
            message = db.get_message_by_frame_id(can_id, force_extended_id=is_extended)
        except KeyError:
            return None
        if message.is_extended_frame != is_extended:
            return None
        plan = self._unique.get((channel, message.name))
        if plan is None:
            plan = self._unique[(channel, message.name)] = DecodePlan(message)
        return plan

    def decode(self, channel: str, can_id: int, is_extended: bool, data: bytes):
        """``(plan, values)`` for a decodable frame, else None."""
        plan = self.plan(channel, can_id, is_extended)
        if plan is None:
            return None
        values = plan.decode(can_id, data)
        return None if values is None else (plan, values)
