"""Reading a trace back (``TraceReader``): every topic, raw frames, decoded signals, ground truth.

Reads what ``wheelleg.hil.record.trace.TraceWriter`` writes and the layouts of older
traces (``/can/`` one message per frame or JSON; ``/decoded/`` recorded live;
``/sim/state`` and ``/controller/debug`` as JSON), also a trace whose writer was killed.
"""
from __future__ import annotations

import heapq
from collections import defaultdict
from functools import cached_property
from pathlib import Path
from typing import Iterator

import numpy as np
from mcap.records import Attachment, Channel, Message, Metadata, Schema

from wheelleg.hil.record import can_batch, float_records, schemas
from wheelleg.hil.record.decode import FrameDecoder
from wheelleg.hil.record.derived import attached_dbs, decoded_columns, rows_columns
from wheelleg.hil.record.frame import Frame, FrameColumns
from wheelleg.hil.record.mcap_read import ChunkMessages, RecordScan, read_records
from wheelleg.hil.record.schemas import CAN_PREFIX, DECODED_PREFIX, EVENTS_TOPIC, SIM_STATE_TOPIC
from wheelleg.hil.record.trace_json import dumps, loads

_CAN_HEAD = schemas.CAN_FRAME_HEAD


class TraceReader:
    """Reads a trace back, also one whose writer was killed (``truncated`` is then True).

    ``decoded`` and ``topic("/decoded/...")`` give a ``/decoded/`` topic as recorded
    (a trace written with ``decode=True``) or derive it from the raw frames
    (``wheelleg.hil.record.derived``) with ``dbs`` (channel -> cantools Database),
    else with the trace's own DBC attachments.
    """

    def __init__(self, path, dbs: dict | None = None):
        self.path = Path(path)
        self.scan = RecordScan()
        self.metadata: dict[str, dict[str, str]] = {}
        self.attachments: dict[str, bytes] = {}
        self.attachment_media_types: dict[str, str] = {}
        self._topics: dict[int, str] = {}
        self._encodings: dict[str, str] = {}  # topic -> message encoding ("cdr": binary /can/)
        self._messages: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
        self._schemas: dict[int, Schema] = {}
        self._schema_of: dict[str, int] = {}  # topic -> schema id
        self._channel_meta: dict[str, dict[str, str]] = {}  # topic -> its channel's metadata
        self._columns: dict[str, FrameColumns] = {}  # channel -> its frames by column, made once
        self._load()
        if dbs:
            self.dbs = dict(dbs)

    # parsed when first needed: a reader of poses or metadata alone skips cantools (~0.3 s a trace)
    @cached_property
    def dbs(self) -> dict:
        """Channel -> cantools Database: the given ones, else the trace's DBC attachments."""
        return attached_dbs(self.attachments, self.metadata.get("run", {}))

    @cached_property
    def _decoder(self) -> FrameDecoder | None:
        return FrameDecoder(self.dbs) if self.dbs else None

    @property
    def decodes(self) -> bool:
        """True when raw frames can be decoded (given databases, or the trace's DBC attachments and channels)."""
        return self._decoder is not None

    def decode_with(self, dbs: dict) -> None:
        """Decode raw frames with ``dbs`` (channel -> cantools Database) where ``/decoded/`` lacks them."""
        self.dbs = dict(dbs)
        self._decoder = FrameDecoder(self.dbs)

    def records(self, topic: str) -> list[tuple[int, bytes]]:
        """``topic``'s messages as stored: (log time ns, record bytes), in file order."""
        return list(self._messages.get(topic, ()))

    def schema(self, topic: str) -> tuple[Schema | None, str, dict[str, str]]:
        """The stored schema of ``topic`` (None: schemaless), its message encoding and channel metadata."""
        return (self._schemas.get(self._schema_of.get(topic, 0)), self._encodings.get(topic, ""),
                self._channel_meta.get(topic, {}))

    def _layout(self, topic: str):
        """The float64-record layout of ``topic`` (``float_records``), None for a JSON (or other) topic."""
        if self._encodings.get(topic) != float_records.MESSAGE_ENCODING:
            return None
        schema = self._schemas.get(self._schema_of.get(topic, 0))
        return float_records.layout_of(schema.name if schema else "", self._channel_meta.get(topic, {}))

    @property
    def truncated(self) -> bool:
        """True when the file ends before its footer (writer killed or file cut)."""
        return not self.scan.complete

    @property
    def topics(self) -> dict[str, int]:
        """Topic -> number of messages."""
        return {topic: len(msgs) for topic, msgs in self._messages.items()}

    def _load(self) -> None:
        messages, topics = self._messages, self._topics
        for record in read_records(self.path, self.scan, by_channel=True):
            if type(record) is ChunkMessages:
                for channel_id, rows in record.by_channel.items():
                    messages[topics[channel_id]].extend(rows)
            elif type(record) is Message:  # a message outside chunks
                messages[topics[record.channel_id]].append((record.log_time, record.data))
            elif isinstance(record, Channel):
                topics[record.id] = record.topic
                self._encodings[record.topic] = record.message_encoding
                self._schema_of[record.topic] = record.schema_id
                self._channel_meta[record.topic] = dict(record.metadata)
            elif isinstance(record, Schema):
                self._schemas[record.id] = record
            elif isinstance(record, Metadata):
                self.metadata[record.name] = dict(record.metadata)
            elif isinstance(record, Attachment):
                self.attachments[record.name] = record.data
                self.attachment_media_types[record.name] = record.media_type

    def topic(self, topic: str) -> list[tuple[int, dict]]:
        """Every message of ``topic`` as (log time ns, payload), in file order.

        A ``/can/`` topic's payloads are {"id", "extended", "dlc", "data" (hex), "error"}
        whichever way the trace stored them; a ``/decoded/`` topic the trace does not
        store is derived from the raw frames (the rows a live-decoded trace reads back as).
        """
        if topic.startswith(DECODED_PREFIX) and topic not in self._messages:
            return self._derived_rows(topic)
        layout = self._layout(topic)
        if layout is not None:  # float64 records: the dicts their JSON records read back as
            return layout.rows(self._messages.get(topic, []), topic)
        if topic.startswith(CAN_PREFIX) and self._encodings.get(topic) == schemas.CAN_FRAME_MESSAGE_ENCODING:
            return [(f.t_ns, {"id": f.arbitration_id, "extended": f.is_extended, "dlc": f.dlc,
                              "data": f.data.hex(), "error": f.is_error})
                    for f in self._channel_frames(topic[len(CAN_PREFIX):], "")]
        return [(t, loads(data)) for t, data in self._messages.get(topic, ())]

    def frames(self, channel: str | None = None, bus: str = "") -> Iterator[Frame]:
        """Raw frames of one channel (or of all, merged by bus time); ``bus``: the role to give them."""
        if channel is not None:
            return self._channel_frames(channel, bus)
        return heapq.merge(*(self._channel_frames(n, bus) for n in self.channels()), key=lambda f: f.t_ns)

    def channels(self) -> list[str]:
        """The CAN channels (interface names) of the trace, sorted."""
        return sorted(t[len(CAN_PREFIX):] for t in self._messages if t.startswith(CAN_PREFIX))

    def _channel_frames(self, channel: str, bus: str) -> Iterator[Frame]:
        topic = CAN_PREFIX + channel
        records = self._messages.get(topic, ())
        if self._encodings.get(topic) != schemas.CAN_FRAME_MESSAGE_ENCODING:  # a JSON trace (older)
            for t_ns, data in records:
                r = loads(data)
                yield Frame(t_ns, channel, r["id"], r["extended"], bytes.fromhex(r["data"]), r["dlc"], bus,
                            r["error"])
            return
        if self._batched(topic):  # one message per bus and window
            unpack = can_batch.unpack
            for t_ns, data in records:
                yield from unpack(data, t_ns, channel, bus)
            return
        schema = self._schemas.get(self._schema_of.get(topic, 0))
        name = schema.name if schema is not None else ""
        if name != schemas.CAN_FRAME_NAME:
            raise ValueError(f"{self.path}: {topic} has schema {name!r} in a layout this reader does not know "
                             f"(it reads {schemas.CAN_FRAMES_NAME} and {schemas.CAN_FRAME_NAME}): a newer trace?")
        head, unpack_from = _CAN_HEAD.size, _CAN_HEAD.unpack_from  # one message per frame (older)
        for t_ns, data in records:
            _, can_id, extended, dlc, error, n = unpack_from(data)
            yield Frame(t_ns, channel, can_id, bool(extended), data[head:head + n], dlc, bus, bool(error))

    def frame_columns(self, channel: str) -> FrameColumns:
        """One channel's frames by column (``FrameColumns``), for readers that take all of them at once.

        Made once per channel and shared by every call (each decoded message of a channel, the
        checks' commands): its arrays are read-only, and its ``data`` list is not to be changed.
        """
        columns = self._columns.get(channel)
        if columns is None:
            topic = CAN_PREFIX + channel
            if self._batched(topic):
                columns = FrameColumns.joined([can_batch.unpack_columns(data, t_ns)
                                               for t_ns, data in self._messages.get(topic, ())])
            else:  # older layouts, frame by frame
                columns = FrameColumns.of(list(self._channel_frames(channel, "")))
            self._columns[channel] = columns.frozen()
        return columns

    def _batched(self, topic: str) -> bool:
        """Whether a ``/can/`` topic holds one message per bus and window (``can_batch``)."""
        schema = self._schemas.get(self._schema_of.get(topic, 0))
        return schema is not None and schema.name == schemas.CAN_FRAMES_NAME and b"uint32[] gap_ns" in schema.data

    def sim_state(self) -> dict[str, np.ndarray]:
        """``/sim/state`` as arrays keyed by field, each shape (n,); {} if absent."""
        return self.columns(SIM_STATE_TOPIC)

    def columns(self, topic: str) -> dict[str, np.ndarray]:
        """A topic of numbers (``/sim/state``, ``/controller/debug``, ...) as one float array per field,
        shape (n,), whether stored as float64 records or JSON; missing, null, not finite -> NaN."""
        layout = self._layout(topic)
        if layout is not None:
            return layout.columns(self._messages.get(topic, []), topic)
        return rows_columns(self.topic(topic))

    def decoded(self, channel: str, message: str) -> dict[str, np.ndarray]:
        """'t' (s) and each signal of one DBC message, shape (n,); {} if none recorded."""
        topic = f"{DECODED_PREFIX}{channel}/{message}"
        if topic in self._messages:
            return rows_columns(self.topic(topic), time_key="t")
        if self._decoder is None:
            return {}
        return decoded_columns(self._decoder, channel, self.frame_columns(channel), message)

    def _derived_rows(self, topic: str) -> list[tuple[int, dict]]:
        channel, _, message = topic[len(DECODED_PREFIX):].partition("/")
        if self._decoder is None or not message:
            return []
        rows = []
        for frame in self.frames(channel):
            hit = None if frame.is_error else self._decoder.decode(
                channel, frame.arbitration_id, frame.is_extended, frame.data)
            if hit is not None and hit[0].name == message:
                rows.append((frame.t_ns, loads(dumps(hit[1]))))  # as a JSON topic reads back (NaN -> None)
        return rows

    def events(self) -> list[dict]:
        """``/scenario/events`` payloads, each with 't' (s)."""
        return [{"t": t / 1e9, **payload} for t, payload in self.topic(EVENTS_TOPIC)]

