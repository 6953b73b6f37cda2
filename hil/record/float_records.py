"""Records of named float64 values (``/sim/state``, ``/controller/debug``): one binary CDR message each.

JSON spent ~700 bytes of text on 22 numbers and compressed to ~195 bytes a
record; the same numbers as float64 in a ROS 2 message (``float64 name`` per
field, CDR) are 4 + 8 n bytes and compress to ~155 (10 s of balance: 1.87 ->
1.49 MB for the two topics). Foxglove plots each field by name over time, as
it did the JSON fields; readers take all records of a topic at once into a
numpy structured array (``columns``).

ROS 2 field names are lower case (``[a-z][a-z0-9_]*``, no ``__``, no trailing
``_``), while the rig's names are not always (``left_L0``, ``FR_foot_z``): the
message definition uses ``ros_name(name)`` and the channel's metadata keeps the
rig's names in order (``FIELDS_KEY``), so ``TraceReader`` gives them back as
they were written. ``TIME_KEY`` names the field whose value is the log time in
seconds (``/sim/state``'s ``t``): not stored, read back as ``log time / 1e9``,
the value the JSON record held.
"""
from __future__ import annotations

import json
import math
import re
import struct
from dataclasses import dataclass

import numpy as np

from wheelleg.hil.record.schemas import CDR_LE

ENCODING, MESSAGE_ENCODING = "ros2msg", "cdr"
FIELDS_KEY, TIME_KEY = "wheelleg_fields", "wheelleg_time_field"  # channel metadata


def ros_name(name: str, taken: set[str]) -> str:
    """A valid ROS 2 field name for ``name``, not in ``taken`` (which it is added to)."""
    text = re.sub(r"_+", "_", re.sub(r"[^a-z0-9_]", "_", name.lower())).strip("_") or "field"
    if not text[0].isalpha():
        text = "f_" + text
    candidate, k = text, 2
    while candidate in taken:
        candidate, k = f"{text}_{k}", k + 1
    taken.add(candidate)
    return candidate


@dataclass(frozen=True)
class FloatLayout:
    """The fields of one topic's records: the rig's names in order, the optional time field."""

    schema_name: str  # e.g. "wheelleg/msg/SimState"
    fields: tuple[str, ...]  # stored, in this order
    time_field: str = ""  # not stored: log time / 1e9
    notes: tuple[str, ...] = ()  # each field's description (unit, meaning): comments in the definition

    @property
    def record_size(self) -> int:
        return 4 + 8 * len(self.fields)

    def message_definition(self, title: str = "") -> str:
        """The ROS 2 message definition: one ``float64`` per field, its description as a comment."""
        taken: set[str] = set()
        lines = [f"# {title}"] if title else []
        if self.time_field:
            lines.append(f"# log time = {self.time_field!r} (s) x 1e9")
        notes = self.notes or ("",) * len(self.fields)
        for name, note in zip(self.fields, notes):
            comment = f"  # {name}: {note}" if note else ("" if ros_name(name, set()) == name else f"  # {name}")
            lines.append(f"float64 {ros_name(name, taken)}{comment}")
        return "\n".join(lines) + "\n"

    def channel_metadata(self) -> dict[str, str]:
        meta = {FIELDS_KEY: json.dumps(list(self.fields))}
        if self.time_field:
            meta[TIME_KEY] = self.time_field
        return meta

    def pack(self, values: dict, topic: str) -> bytes:
        """One record of ``values`` (field -> number; a field it lacks: NaN); TypeError for a non-number."""
        numbers = [values.get(k, math.nan) for k in self.fields]
        try:
            return struct.pack(f"<4s{len(self.fields)}d", CDR_LE, *numbers)
        except struct.error:  # None (JSON's null) is NaN; anything else that is not a number is refused
            numbers = [math.nan if v is None else v for v in numbers]
            bad = next((k for k, v in zip(self.fields, numbers) if not _is_number(v)), None)
            if bad is not None:
                raise TypeError(f"{topic}[{bad!r}] must be a number, got {values[bad]!r}") from None
            return struct.pack(f"<4s{len(self.fields)}d", CDR_LE, *numbers)

    def pack_known(self, values: dict, compiled) -> bytes | None:
        """``pack`` of ``values`` whose every key is a field or the time field and every value a float or an
        int, in C by ``compiled`` (``wheelleg.hil.fast.core()``): the same bytes; None otherwise (the
        caller checks and packs)."""
        if type(values) is not dict or type(self.fields) is not tuple:
            return None
        return compiled.pack_floats(self.fields, values, self.time_field or _NO_FIELD)

    def columns(self, records: list[tuple[int, bytes]], topic: str) -> dict[str, np.ndarray]:
        """Every record at once: the time field (if any) and each field, shape (n,), not finite -> NaN."""
        if not records:
            return {}
        if any(len(data) != self.record_size for _, data in records):
            raise ValueError(f"{topic}: a record is not {self.record_size} bytes ({len(self.fields)} float64)")
        dtype = np.dtype([("cdr", "V4")] + [(f"f{i}", "<f8") for i in range(len(self.fields))])
        table = np.frombuffer(b"".join(data for _, data in records), dtype=dtype)
        out = {}
        if self.time_field:
            out[self.time_field] = np.array([t for t, _ in records], dtype=np.int64) / 1e9
        for i, name in enumerate(self.fields):
            column = table[f"f{i}"].copy()
            column[~np.isfinite(column)] = math.nan  # as the JSON records (null) read back
            out[name] = column
        return out

    def rows(self, records: list[tuple[int, bytes]], topic: str) -> list[tuple[int, dict]]:
        """Each record as (log time ns, {field: value}), non-finite values None: a JSON record's dict."""
        columns = self.columns(records, topic)
        names = list(columns)
        lists = [[None if math.isnan(v) else v for v in columns[name].tolist()] for name in names]
        return [(t, dict(zip(names, values))) for (t, _), values in zip(records, zip(*lists))]


_NO_FIELD = object()  # the time field of a layout without one: no key of a dict


def layout_of(schema_name: str, channel_metadata: dict[str, str]) -> FloatLayout | None:
    """The layout a channel was written with, or None when it is not a float-record channel."""
    fields = channel_metadata.get(FIELDS_KEY)
    if fields is None:
        return None
    return FloatLayout(schema_name, tuple(json.loads(fields)), channel_metadata.get(TIME_KEY, ""))


def _is_number(value) -> bool:
    try:
        struct.pack("<d", value)
    except struct.error:
        return False
    return True
