"""The rig's trace: one MCAP file per run, written as the run goes.

Channels (Foxglove lists and plots them all; see ``wheelleg.hil.record.schemas``
for the field lists and units):

- ``/can/<channel>``      one binary message per bus and ``can_window_s`` of bus time
                          (100 ms) holding its frames as arrays
                          (ROS 2 msg schema, CDR: ``can_batch``); log time = publish
                          time = its first frame's bus time (ns). Older traces: one
                          message per frame (``schemas.CAN_FRAME_MSG``), still read.
- ``/decoded/<channel>/<Message>``  only with ``decode=True`` (else readers derive it):
                          the frame's DBC signals as numbers (CyberGear: plus the
                          fields of the 29-bit id), the frame's log time.
- ``/sim/state``          ground truth each control period, one float64 per field
                          (ROS 2 msg, CDR: ``float_records``; t = log time, SI units).
- ``/controller/debug``   (or any topic of named numbers, ``TraceWriter.numbers``) float64 the same way.
- ``/scenario/events``    {"kind": ..., ...}.
- any other topic         generic JSON (``TraceWriter.message``).

``/scenario/events``, ``/bus/load`` and generic topics are JSON with a JSON Schema.

Metadata records (name -> {str: str}) and attachments (DBC files, MJCF) are
written first, so even a trace whose writer was killed carries them.

``TraceReader`` (``trace_reader.py``, importable from here too) reads them back.

Usage::

    with TraceWriter(path, metadata={"run": {...}}, attachments=[...], dbs={"can1": db1}) as trace:
        trace.frame(Frame(t_ns, "can1", 0x201, False, data, 8))
        trace.sim_state(t_ns, state)
    reader = TraceReader(path)
    reader.sim_state()["pitch"]   # (n,) rad

Cost (tools/bench_trace.py, this 2-core machine, with orjson): ~1 us per raw
frame. With ``decode=True``, ``/decoded/`` rows are made in batches: each message's frames wait
(``decode_batch`` of them, or until their chunk closes) and are decoded in one
numpy pass (``DecodePlan.decode_columns``, JSON by column: ``trace_json.json_rows``),
~2 us more per frame instead of ~5 one by one, the same bytes; within a chunk a
topic's messages stay in time order, the chunk's topics are not interleaved by
time (readers order by the message index).
Without orjson the stdlib json module is used and decoding costs ~11 us more
per frame.
"""
from __future__ import annotations

import struct
from collections import deque
from numbers import Integral
from pathlib import Path
from typing import Sequence

from mcap.records import Schema

from wheelleg.hil import fast
from wheelleg.hil.record import can_batch, float_records, schemas
from wheelleg.hil.record.decode import FrameDecoder
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.mcap_chunks import ChunkedMcapWriter
from wheelleg.hil.record.schemas import CAN_PREFIX, DECODED_PREFIX, EVENTS_TOPIC, SIM_STATE_TOPIC
from wheelleg.hil.record.trace_json import dumps, json_rows, loads, orjson  # noqa: F401 (loads, orjson: re-exported)
from wheelleg.hil.record.trace_reader import TraceReader  # noqa: F401 (re-exported: the reader of these traces)

_RESERVED = (CAN_PREFIX, DECODED_PREFIX, SIM_STATE_TOPIC, EVENTS_TOPIC)
_MAX_ID = 0x1FFFFFFF  # 29-bit identifier
_HELD_BYTES = 23  # a held classic frame's share of its /can/ record (gap, id, flags, dlc, length, 8 data)


# -- writing --------------------------------------------------------------------------
class TraceWriter:
    """Writes one run's MCAP trace; a context manager (``start`` ... ``finish``).

    ``metadata``: record name -> {key: str value}, e.g. {"run": {"scenario": ...}}.
    ``attachments``: (name, data, media type), e.g. the DBC files and the MJCF.
    ``dbs``: channel -> cantools Database used for ``/decoded/...`` when ``decode`` is True;
    by default (``decode=False``) only raw frames are recorded and readers derive the
    signals (``TraceReader.decoded``, ``wheelleg export`` for Foxglove).
    ``flush_interval_s``: wall-clock bound on what a killed process loses
    (None: close chunks by size and bus time only, for byte-identical files).
    ``decode_batch``: frames of one message decoded together (1: each as it
    comes, for a real-time loop that must not stall on a batch).
    ``can_window_s``: each bus's frames of one such window of bus time are one ``/can/``
    message (100 ms: the windows of ``/bus/load``; docs/measurements.md has the sizes).
    ``write_behind``: closed chunks are compressed and written by a worker thread
    (``mcap_chunks``), so a real-time loop does not wait 1-2 ms for them.
    ``defer_close``: the lumps of work wait for ``housekeeping``, which a real-time loop
    calls in its slack between steps: a bus's finished ``/can/`` window is packed there
    (0.1-0.3 ms each, every 100 ms), and a chunk due to close closes there (``mcap_chunks``).
    """

    def __init__(self, path, *, metadata: dict[str, dict[str, str]],
                 attachments: Sequence[tuple[str, bytes, str]] = (), dbs: dict | None = None,
                 decode: bool = False, compression: str = "zstd", chunk_size: int = 512 * 1024,
                 chunk_span_s: float = 0.5, flush_interval_s: float | None = 1.0, decode_batch: int = 256,
                 sim_state_fields: dict[str, str] | None = None, can_window_s: float = 0.1,
                 write_behind: bool = False, defer_close: bool = False):
        """``sim_state_fields``: the /sim/state fields every record must have (name -> unit; default:
        the wheel-legged robot's, ``schemas.SIM_STATE_FIELDS``)."""
        self.path = Path(path)
        self._metadata = _checked_metadata(metadata)
        self._sim_fields = schemas.SIM_STATE_FIELDS if sim_state_fields is None else dict(sim_state_fields)
        self._attachments = [(str(n), bytes(d), str(t)) for n, d, t in attachments]
        self._decoder = FrameDecoder(dbs) if (dbs and decode) else None
        self._options = dict(compression=compression, chunk_size=chunk_size,
                             chunk_span_ns=round(chunk_span_s * 1e9), flush_interval_s=flush_interval_s,
                             before_close=self._before_close, write_behind=write_behind,
                             defer_close=defer_close)
        self._decode_batch = max(1, int(decode_batch))
        self._can_window_ns = round(can_window_s * 1e9)
        if not 0 < self._can_window_ns <= can_batch.MAX_GAP_NS:
            raise ValueError(f"can_window_s must be > 0 and <= {can_batch.MAX_GAP_NS / 1e9:.2f} s, got {can_window_s!r}")
        self._held: dict[str, tuple[int, list[Frame]]] = {}  # channel -> (window, its frames not yet written)
        self._held_count = 0  # frames held since the chunk opened (an upper bound: some may be written)
        self._defer = defer_close
        self._done_windows: deque[tuple[str, list[Frame]]] = deque()  # finished windows not yet packed (defer)
        self._pending: dict[object, _Pending] = {}  # DecodePlan -> its frames not yet decoded
        self._file = None
        self._mcap: ChunkedMcapWriter | None = None
        self._finished = False
        self._compiled = fast.core()  # float records packed in C when it is built (``wheelleg.hil.fast``)
        self._can_ids: dict[str, int] = {}  # channel -> MCAP channel id of /can/<channel>
        self._topic_ids: dict[str, int] = {}  # any topic -> MCAP channel id
        self._decoded_ids: dict[object, int] = {}  # DecodePlan (one per channel and message) -> id
        self._schema_ids: dict[bytes, int] = {}
        self._layouts: dict[str, float_records.FloatLayout] = {}  # float64-record topic -> its fields
        self._field_sets: dict[str, frozenset] = {}

    # -- lifecycle ---------------------------------------------------------
    def start(self) -> "TraceWriter":
        """Open the file and write header, metadata and attachments (idempotent)."""
        if self._finished:
            raise RuntimeError(f"{self.path}: trace already finished")
        if self._mcap is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "wb")
            self._mcap = ChunkedMcapWriter(self._file, **self._options)
            self._mcap.start(profile="", library="wheelleg-hil trace")
            for name, record in self._metadata.items():
                self._mcap.add_metadata(name, record)
            for name, data, media_type in self._attachments:
                self._mcap.add_attachment(name, media_type, data)
        return self

    def finish(self) -> None:
        """Write the summary and footer and close the file (idempotent)."""
        if self._finished:
            return
        self.start()
        self._mcap.finish()
        self._file.close()
        self._finished = True

    close = stop = finish  # stop: as a recorder sink

    def housekeeping_pending(self) -> bool:
        """Whether ``housekeeping`` has work: a finished window to pack, or a chunk due to close."""
        mcap = self._mcap
        return bool(self._done_windows) or (mcap is not None and mcap.close_due)

    def housekeeping(self) -> bool:
        """One piece of the work ``defer_close`` put off: the oldest finished ``/can/`` window
        packed, else the chunk closed if it is due. True if there was one."""
        mcap = self._mcap
        if mcap is None or self._finished:
            return False
        if self._done_windows:
            self._write_batch(*self._done_windows.popleft())
            return True
        return mcap.close_if_due()

    def add_metadata(self, name: str, record: dict[str, str]) -> None:
        """One more metadata record (e.g. totals known only at the end of a run)."""
        checked = _checked_metadata({name: record})
        self._writer().add_metadata(name, checked[name])

    def __enter__(self) -> "TraceWriter":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.finish()

    def _writer(self) -> ChunkedMcapWriter:
        if self._mcap is None or self._finished:
            self.start()  # raises once finished
        return self._mcap

    # -- channels --------------------------------------------------------------
    def _channel(self, topic: str, schema_name: str, schema: dict | str) -> int:
        """The channel of ``topic``: JSON with ``schema`` (a JSON Schema), or CDR with a ros2msg text."""
        channel_id = self._topic_ids.get(topic)
        if channel_id is None:
            mcap = self._writer()
            binary = isinstance(schema, str)
            text = schema.encode() if binary else schemas.schema_bytes(schema)
            schema_id = self._schema_ids.get(text)
            if schema_id is None:
                schema_id = self._schema_ids[text] = mcap.register_schema(
                    schema_name, schemas.CAN_FRAME_ENCODING if binary else "jsonschema", text)
            channel_id = self._topic_ids[topic] = mcap.register_channel(
                topic, schemas.CAN_FRAME_MESSAGE_ENCODING if binary else "json", schema_id)
        return channel_id

    def copy_channel(self, topic: str, schema: Schema | None, message_encoding: str,
                     metadata: dict[str, str] | None = None) -> int:
        """A channel with another trace's schema, encoding and channel metadata (its records are then
        ``copy``-ed as they are)."""
        mcap = self._writer()
        schema_id = 0
        if schema is not None:
            schema_id = self._schema_ids.get(schema.data)
            if schema_id is None:
                schema_id = self._schema_ids[schema.data] = mcap.register_schema(schema.name, schema.encoding,
                                                                                 schema.data)
        channel_id = self._topic_ids[topic] = mcap.register_channel(topic, message_encoding, schema_id, metadata)
        return channel_id

    def copy(self, channel_id: int, t_ns: int, record: bytes) -> None:
        """One message of a ``copy_channel`` channel, its bytes as stored."""
        self._writer().add_message(channel_id, t_ns, record)

    def _can_channel(self, channel: str) -> int:
        if not isinstance(channel, str) or not channel or "/" in channel or len(channel.split()) != 1:
            raise ValueError(f"bad CAN channel name {channel!r}")
        channel_id = self._can_ids[channel] = self._channel(CAN_PREFIX + channel, schemas.CAN_FRAMES_NAME,
                                                            schemas.CAN_FRAMES_MSG)
        return channel_id

    def _decoded_channel(self, channel: str, plan) -> int:
        channel_id = self._decoded_ids.get(plan)
        if channel_id is None:
            schema = schemas.decoded_schema(plan.message, dict(plan.id_units), payload_optional=plan.bare_requests)
            channel_id = self._channel(f"{DECODED_PREFIX}{channel}/{plan.name}", schema["title"], schema)
            self._decoded_ids[plan] = channel_id
        return channel_id

    # -- records -------------------------------------------------------------------
    def frame(self, frame: Frame) -> None:
        """One CAN frame at its bus time; also decoded if ``decode`` and a DBC of its channel knows it."""
        self.on_frames([frame])

    on_frame = frame  # one frame, as a recorder sink would get it

    def on_frames(self, frames: Sequence[Frame]) -> None:
        """Frames in time order (a recorder sink, ``wheelleg.hil.bus.recorder.FrameSink``).

        Each bus's frames of one ``can_window_s`` window of bus time are held and
        written as one ``/can/`` message when a frame of a later window comes or
        the chunk closes (``can_batch``); the chunk is closed after them if due.
        """
        mcap = self._mcap
        if mcap is None or self._finished:
            mcap = self._writer()
        window, held, decoder = self._can_window_ns, self._held, self._decoder
        for f in frames:  # a bad frame raises after the frames before it are kept
            channel, arbitration_id, t_ns = f.channel, f.arbitration_id, f.t_ns
            if not 0 <= arbitration_id <= _MAX_ID:
                raise ValueError(f"{channel}: arbitration id {arbitration_id!r} outside 0..0x1FFFFFFF")
            if (t_ns.__class__ is not int and not isinstance(t_ns, Integral)) or t_ns < 0:
                raise ValueError(f"t_ns must be an int >= 0 (ns), got {t_ns!r}")
            key = t_ns // window
            batch = held.get(channel)
            if batch is None or batch[0] != key or t_ns < batch[1][-1].t_ns:  # a later window, or out of order
                if batch is not None:
                    if self._defer:
                        self._done_windows.append((channel, batch[1]))
                    else:
                        self._write_batch(channel, batch[1])
                elif channel not in self._can_ids:
                    self._can_channel(channel)
                batch = held[channel] = (key, [])
            batch[1].append(f)
            if decoder is not None and not f.is_error:
                plan = decoder.plan(channel, arbitration_id, f.is_extended)
                if plan is not None:
                    self._decode(plan, channel, t_ns, arbitration_id, f.data)
        if frames:
            self._held_count += len(frames)
            mcap.flush_if_due(frames[-1].t_ns, held_bytes=_HELD_BYTES * self._held_count if held else 0)

    def _write_batch(self, channel: str, frames: list[Frame]) -> None:
        self._mcap.add_messages(self._can_ids[channel], [frames[0].t_ns], [can_batch.pack(frames)])

    def _before_close(self) -> None:
        """Every held frame into the open chunk (called before a chunk closes): ``/can/``, ``/decoded/``."""
        held, self._held, self._held_count = self._held, {}, 0
        done = self._done_windows
        while done:  # a bus's finished windows before its held one: each /can/ channel in time order
            self._write_batch(*done.popleft())
        for channel, (_, frames) in held.items():
            self._write_batch(channel, frames)
        self._write_decoded()

    def _decode(self, plan, channel: str, t_ns: int, arbitration_id: int, data: bytes) -> None:
        """The frame's ``/decoded/`` row: now (``decode_batch`` 1), or held for its message's batch."""
        if self._decode_batch == 1:
            values = plan.decode(arbitration_id, data)
            if values is not None:
                self._mcap.add_message(self._decoded_channel(channel, plan), t_ns, dumps(values))
            return
        pending = self._pending.get(plan)  # a chunk that closes first takes the batch along
        if pending is None:
            pending = self._pending[plan] = _Pending(channel)
        pending.can_ids.append(arbitration_id)
        pending.payloads.append(data)
        times = pending.t_ns
        times.append(t_ns)
        if len(times) >= self._decode_batch:
            self._write_plan(plan, pending)

    def _write_decoded(self) -> None:
        """Every held frame decoded into the open chunk (called before a chunk closes)."""
        for plan, pending in self._pending.items():
            if pending.t_ns:
                self._write_plan(plan, pending)

    def _write_plan(self, plan, pending: "_Pending") -> None:
        times = pending.t_ns
        batch = plan.decode_columns(pending.can_ids, pending.payloads)
        if batch is not None:
            records = json_rows(*batch, len(times))
        else:  # one by one; frames that do not decode (wrong length...) stay raw only
            rows = [plan.decode(i, d) for i, d in zip(pending.can_ids, pending.payloads)]
            times = [t for t, row in zip(times, rows) if row is not None]
            records = [dumps(row) for row in rows if row is not None]
        if records:
            self._mcap.add_messages(self._decoded_channel(pending.channel, plan), times, records)
        pending.clear()

    def sim_state(self, t_ns: int, state: dict[str, float]) -> None:
        """Ground truth at ``t_ns``: the contract's fields (``sim_state_fields``) + extras, float64 each.

        ``t`` (s) is the log time (``t_ns``), not stored. The first record's fields are the
        topic's (``float_records``); a later one may lack an extra (NaN), not add one.
        Every value must be a real number.
        """
        self._check_sim_fields(state)
        layout = self._layouts.get(SIM_STATE_TOPIC) or self.prepare_sim_state(state)
        self._put_floats(SIM_STATE_TOPIC, layout, t_ns, state, "sim_state")

    def prepare_sim_state(self, state: dict[str, float]):
        """``/sim/state``'s channel for records of ``state``'s fields, registered now if it is not yet (the
        first ``sim_state`` does it otherwise: ~1 ms of schema building, which a real-time loop pays
        before its clock starts). Returns its layout."""
        layout = self._layouts.get(SIM_STATE_TOPIC)
        if layout is None:
            self._check_sim_fields(state)
            fields = tuple(k for k in state if k != "t")
            extra = [k for k in fields if k not in self._sim_fields]
            schema = schemas.sim_state_schema(extra, self._sim_fields)
            layout = float_records.FloatLayout("wheelleg/msg/SimState", fields, "t",
                                               tuple(schema["properties"][k].get("description", "") for k in fields))
            self._float_channel(SIM_STATE_TOPIC, layout, schema["description"])
        return layout

    def _check_sim_fields(self, state: dict) -> None:
        missing = [k for k in self._sim_fields if k != "t" and k not in state]
        if missing:
            raise ValueError(f"sim_state is missing {missing}")

    def numbers(self, topic: str, t_ns: int, values: dict, schema: dict) -> None:
        """Named numbers on ``topic``, float64 each (``float_records``): ``schema`` is a JSON Schema of
        numbers (``schemas.described_schema``) whose properties, in order, are the fields and their
        descriptions; a value it does not name is refused, one it lacks is NaN, None is NaN."""
        if not topic.startswith("/") or topic.startswith(_RESERVED):
            raise ValueError(f"topic {topic!r} must start with '/' and not be one of {_RESERVED}")
        layout = self._layouts.get(topic)
        if layout is None:
            props = schema["properties"]
            name = "wheelleg/msg/" + schema["title"].rpartition(".")[2]
            layout = float_records.FloatLayout(name, tuple(props), "",
                                               tuple(p.get("description", "") for p in props.values()))
            self._float_channel(topic, layout, schema.get("description", schema["title"]))
        self._put_floats(topic, layout, t_ns, values, topic)

    def _float_channel(self, topic: str, layout, title: str) -> None:
        mcap = self._writer()
        schema_id = mcap.register_schema(layout.schema_name, float_records.ENCODING,
                                         layout.message_definition(title).encode())
        self._topic_ids[topic] = mcap.register_channel(topic, float_records.MESSAGE_ENCODING, schema_id,
                                                       layout.channel_metadata())
        self._layouts[topic] = layout
        self._field_sets[topic] = frozenset(layout.fields) | {layout.time_field} - {""}

    def _put_floats(self, topic: str, layout, t_ns: int, values: dict, what: str) -> None:
        # every key known, every value a number: packed in C at once; anything else checked here first
        record = None if self._finished or self._compiled is None else layout.pack_known(values, self._compiled)
        if record is None:
            unknown = values.keys() - self._field_sets[topic]
            if unknown:
                raise ValueError(f"{what}: {sorted(unknown)} not among the fields of its first record "
                                 f"{list(layout.fields)}")
            if self._finished:
                raise RuntimeError(f"{self.path}: trace already finished")
        try:
            self._mcap.add_message(self._topic_ids[topic], t_ns, layout.pack(values, what) if record is None else record)
        except struct.error as exc:
            raise ValueError(f"t_ns must be an int >= 0 (ns), got {t_ns!r}") from exc

    def event(self, t_ns: int, kind: str, **fields) -> None:
        """A scenario event on ``/scenario/events``: {"kind": kind, **fields}."""
        if not isinstance(kind, str) or not kind:
            raise ValueError(f"event kind must be a non-empty str, got {kind!r}")
        channel_id = self._channel(EVENTS_TOPIC, "wheelleg.ScenarioEvent", schemas.EVENT)
        self._put(channel_id, t_ns, {"kind": kind, **fields})

    def message(self, topic: str, t_ns: int, payload: dict, schema_name: str,
                schema: dict | None = None) -> None:
        """A generic JSON message; the schema is ``schema`` or inferred from the first payload."""
        if not topic.startswith("/") or topic.startswith(_RESERVED):
            raise ValueError(f"topic {topic!r} must start with '/' and not be one of {_RESERVED}")
        if not isinstance(payload, dict):
            raise TypeError(f"{topic}: payload must be a dict, got {type(payload).__name__}")
        channel_id = self._topic_ids.get(topic)
        if channel_id is None:
            channel_id = self._channel(topic, schema_name, schema or schemas.inferred_schema(schema_name, payload))
        self._put(channel_id, t_ns, payload)

    def _put(self, channel_id: int, t_ns: int, payload: dict) -> None:
        if self._finished:
            raise RuntimeError(f"{self.path}: trace already finished")
        try:
            data = dumps(payload)
        except TypeError as exc:
            raise TypeError(f"{self.path}: cannot encode {payload!r} as JSON: {exc}") from exc
        try:
            self._mcap.add_message(channel_id, t_ns, data)
        except struct.error as exc:
            raise ValueError(f"t_ns must be an int >= 0 (ns), got {t_ns!r}") from exc


class _Pending:
    """One message's frames waiting to be decoded: parallel lists."""

    __slots__ = ("channel", "t_ns", "can_ids", "payloads")

    def __init__(self, channel: str):
        self.channel = channel
        self.t_ns: list[int] = []
        self.can_ids: list[int] = []
        self.payloads: list[bytes] = []

    def clear(self) -> None:
        self.t_ns, self.can_ids, self.payloads = [], [], []


def _checked_metadata(metadata: dict) -> dict[str, dict[str, str]]:
    out = {}
    for name, record in metadata.items():
        if not isinstance(record, dict):
            raise TypeError(f"metadata[{name!r}] must be a dict of str, got {type(record).__name__}")
        for key, value in record.items():
            if not isinstance(key, str) or not isinstance(value, str):
                raise TypeError(f"metadata[{name!r}][{key!r}] must be str -> str, got {value!r}")
        out[str(name)] = dict(record)
    return out
