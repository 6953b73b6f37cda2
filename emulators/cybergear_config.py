"""A CyberGear's stored parameter table on the bus: types 8, 9 and 19 (docs/protocols.md, parameter table).

None of the three is in the manual; each follows the public driver that uses it:

* Type 19 (0x13), the debugger's "parameter table": the motor answers the
  whole table 0x0000-0x302F in index order, a numeric entry as one frame
  (fragment 4), a string as fragment 0 then 6, 7 and 8 with six characters
  each (the python-cybergear parser), whatever the request's payload: the
  motor's 64-bit MCU UID (python-cybergear sends the type-0 answer back) or
  the debugger's fixed bytes.
* Type 9, read one entry: a type-9 frame with the index, the entry's data-type
  code in byte 2 (``TYPE_CODES``, CyberGearDriver's) and the value from byte 4;
  a string entry as four frames of four characters (part 0..3 in byte 3).
  Unknown indices: silence.
* Type 8, write one entry: taken when the entry is writable and the value
  within the manual's range; no answer (no source gives one). The stored
  values are what types 8, 9 and 19 see; the runtime 0x70xx parameters the
  motor runs on (types 17/18) are not changed by them, as a real motor loads
  them only at power-up.

Live entries (CAN_ID, CAN_MASTER, temperatures, bus voltage, angle, speed,
current) are the motor's own state, passed in by the caller as ``live``.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import can

from wheelleg.dbc import CYBERGEAR_FILES, load_file
from wheelleg.dbc import cybergear as cg
from wheelleg.dbc.codec import MessageCodec
from wheelleg.emulators.cybergear_table import BY_INDEX, TABLE, Entry
from wheelleg.emulators.device import frame

FRAGMENT_VALUE, FRAGMENT_START, TEXT_FRAGMENTS = 4, 0, (6, 7, 8)
TEXT_BYTES = 6  # characters per string fragment
FULL_DLC = 8
VALUE_BYTES = {"u8": 1, "u16": 2, "i16": 2, "u32": 4, "i32": 4, "f32": 4}
TYPE_CODES = {"u8": 0x00, "u16": 0x02, "i16": 0x03, "u32": 0x04, "i32": 0x05, "f32": 0x06, "str": 0x0A}
READ_TEXT_PARTS, READ_TEXT_BYTES = 4, 4  # a type-9 string answer: four frames of four characters


class StoredTable:
    """One motor's table 0x0000-0x302F: power-up values from the manual, type-8 writes, answers."""

    def __init__(self, position_range: str = "12.5"):
        db = load_file(CYBERGEAR_FILES[position_range])
        self._table = MessageCodec.of(db.get_message_by_name("CG_ParamTable"))
        self._read = MessageCodec.of(db.get_message_by_name("CG_ConfigRead"))
        self._write = MessageCodec.of(db.get_message_by_name("CG_ConfigWrite"))
        self._text = MessageCodec.of(load_file(cg.ID_DBC).get_message_by_name("CG_ParamTableText"))
        self._read_text = MessageCodec.of(load_file(cg.ID_DBC).get_message_by_name("CG_ConfigReadText"))
        self.values = {e.name: e.default for e in TABLE}

    def value(self, entry: Entry, live: Mapping):
        return live.get(entry.name, self.values[entry.name])

    def write(self, data: bytes) -> None:
        """Type 8: store the value if the entry is writable and the value within its range."""
        if len(data) < 4:
            return
        entry = BY_INDEX.get(int.from_bytes(data[:2], "little"))
        if entry is None or not entry.writable or len(data) < 4 + VALUE_BYTES[entry.kind]:
            return
        value = self._write.decode_raw(data.ljust(FULL_DLC, b"\0"))[entry.name]
        if isinstance(value, float) and not math.isfinite(value):
            return
        if entry.lo <= value <= entry.hi:
            self.values[entry.name] = value

    def read(self, data: bytes, live: Mapping, motor: int, host: int, now_s: float) -> list[can.Message]:
        """Type 9: one entry (a string in four frames), or silence for an unknown index or a short request."""
        entry = BY_INDEX.get(int.from_bytes(data[:2], "little")) if len(data) >= 2 else None
        if entry is None:
            return []
        can_id = cg.reply_id(cg.T_CONFIG_READ, motor, host)
        if entry.kind == "str":
            text = self._text_bytes(entry).ljust(READ_TEXT_PARTS * READ_TEXT_BYTES, b"\0")
            return [frame(can_id, self._read_text.encode_raw(
                        {"Index": entry.index, "TypeCode": TYPE_CODES["str"], "Part": part,
                         "Text": int.from_bytes(text[part * READ_TEXT_BYTES:(part + 1) * READ_TEXT_BYTES], "little")}),
                          True, now_s) for part in range(READ_TEXT_PARTS)]
        payload = self._read.encode_raw({"Index": entry.index, "TypeCode": TYPE_CODES[entry.kind],
                                         entry.name: self._raw(entry, live)})
        return [frame(can_id, payload, True, now_s)]

    def dump(self, live: Mapping, motor: int, host: int, now_s: float) -> list[can.Message]:
        """Type 19: the whole table (whatever the request carried)."""
        frames = []
        for entry in TABLE:
            if entry.kind == "str":
                frames += self._text_frames(entry, motor, host, now_s)
            else:
                payload = self._table.encode_raw({"Index": entry.index, entry.name: self._raw(entry, live)})
                frames.append(frame(cg.table_id(FRAGMENT_VALUE, motor, host), payload, True, now_s))
        return frames

    def _raw(self, entry: Entry, live: Mapping):
        value = self.value(entry, live)
        return float(value) if entry.kind == "f32" else int(value)

    def _text_bytes(self, entry: Entry) -> bytes:
        return str(self.value(entry, {})).encode("latin-1")

    def _text_frames(self, entry: Entry, motor: int, host: int, now_s: float) -> list[can.Message]:
        text = self._text_bytes(entry)[:TEXT_BYTES * len(TEXT_FRAGMENTS)]
        frames = [frame(cg.table_id(FRAGMENT_START, motor, host),
                        self._text.encode_raw({"Index": entry.index, "Text": 0}), True, now_s)]
        for n, fragment in enumerate(TEXT_FRAGMENTS):
            chunk = text[n * TEXT_BYTES:(n + 1) * TEXT_BYTES].ljust(TEXT_BYTES, b"\0")
            payload = self._text.encode_raw({"Index": entry.index, "Text": int.from_bytes(chunk, "little")})
            frames.append(frame(cg.table_id(fragment, motor, host), payload, True, now_s))
        return frames
