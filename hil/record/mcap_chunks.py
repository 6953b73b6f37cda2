"""A lean chunked MCAP writer for the rig's hot path (its reader: ``mcap_read``).

Why not ``mcap.writer.Writer`` for messages: it builds a ``Message`` dataclass,
updates statistics and writes the record through ``RecordBuilder`` field by
field, about 8 us per message on the rig's machine. The rig records ~20,000
messages per simulated second at >= 10x real time, so that alone would eat the
whole time budget. Here a message is one ``struct.pack`` into the open chunk
and two list appends for its index (well under 1 us). Within a chunk each
channel's messages sit together (one buffer per channel, joined when the chunk
closes): like records compress better side by side (a few per cent less file
than interleaved by time), and readers take the order from the message index.
Every other record
(header, schema, channel, chunk, metadata, attachment, summary, footer) is
mcap's own dataclass written by mcap's own code, so the file layout stays
mcap's; only the Message and MessageIndex records are packed here, by the
spec's field order (https://mcap.dev/spec: opcode u8, length u64, then fields).

Crash safety: a chunk is closed and flushed to the OS when it reaches
``chunk_size`` bytes, spans ``chunk_span_ns`` of log time, or when
``flush_interval_s`` of wall-clock time passed since the last flush. A killed
process then loses only the open chunk; ``mcap_read.read_records`` reads what
was written up to the first short or corrupt record (a file without footer).

Write-behind (``write_behind=True``, real-time runs): a closed chunk is joined, indexed,
compressed, checksummed and written by one worker thread, in order, so the loop that closed it
goes on at once (zstd, crc32 and the file write release the GIL); a record written
outside chunks, and ``finish``, wait for the worker first. A killed process then
loses the open chunk and the one being written. Only work that mostly releases the GIL
belongs there: Python work on the worker holds the GIL the loop waits for between its
steps (docs/measurements.md, Real time: packing the ``/can/`` windows there doubled the jitter).

Deferred closes (``defer_close=True``, real-time runs): a chunk that is due to close (by size,
span or the wall-clock flush) is only marked (``close_due``) and closed when the owner calls
``close_if_due``, which a real-time loop does in the slack after a step (hil/run/realtime.py):
the close (the held ``/can/`` windows packed, the chunk handed over) then does not land on top
of a step. A chunk that grows to twice ``chunk_size`` closes at once all the same.
"""
from __future__ import annotations

import struct
import time
import zlib
from concurrent.futures import Future, ThreadPoolExecutor
from typing import BinaryIO

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (Attachment, AttachmentIndex, Channel, Chunk, ChunkIndex, DataEnd,
                          Footer, Header, Metadata, MetadataIndex, Schema, Statistics, SummaryOffset)
from mcap.writer import MCAP0_MAGIC

try:
    import zstandard
except ImportError:  # mcap lists it as optional: no compression then (mcap_read reads such files with mcap's own code)
    zstandard = None

# The MCAP Message record (this writer's and ``mcap_read``'s): a record head (opcode, record
# length), then these fields (channel id, sequence, log time, publish time), then the data.
RECORD_HEAD = struct.Struct("<BQ")
MESSAGE_FIELDS = struct.Struct("<HIQQ")
_MESSAGE_HEAD = struct.Struct(RECORD_HEAD.format + MESSAGE_FIELDS.format[1:])
_INDEX_HEAD = struct.Struct("<BQHI")  # opcode, record length, channel id, entries byte length
_FOOTER_CRC_PREFIX = struct.Struct("<BQQQ")  # opcode, length, summary start, summary offset start
OP_MESSAGE, _OP_MESSAGE_INDEX = int(Opcode.MESSAGE), int(Opcode.MESSAGE_INDEX)  # plain ints pack 2x faster
LIBRARY = "wheelleg-hil mcap_chunks (mcap-python records)"


def _record_bytes(record) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return builder.end()


class ChunkedMcapWriter:
    """Chunked, indexed MCAP writer; messages go through the fast path ``add_message``.

    ``stream`` is a binary file opened for writing; the writer flushes it after
    every chunk but never closes it. ``compression`` is ``"zstd"`` or ``""``.
    ``before_close()``, if given, is called before a chunk is closed: the
    caller's messages held back for a batch go into that chunk
    (``add_messages``).
    """

    def __init__(self, stream: BinaryIO, *, chunk_size: int = 512 * 1024,
                 chunk_span_ns: int = 500_000_000, flush_interval_s: float | None = 1.0,
                 compression: str = "zstd", before_close=None, write_behind: bool = False,
                 defer_close: bool = False):
        if compression not in ("zstd", ""):
            raise ValueError(f"compression must be 'zstd' or '', not {compression!r}")
        if compression == "zstd" and zstandard is None:
            compression = ""
        self._stream = stream
        self._before_close = before_close
        self._chunk_size = int(chunk_size)
        self._chunk_span_ns = int(chunk_span_ns)
        self._flush_interval_s = flush_interval_s
        self._compression = compression
        self._compressor = zstandard.ZstdCompressor(level=1) if compression == "zstd" else None
        self._records = bytearray()  # schema and channel records of the open chunk (its start)
        # channel id -> (its messages' records, uncompressed; [t0, offset0, t1, offset1, ...]
        # with offsets into that buffer): the open chunk's messages, by channel
        self._runs: dict[int, tuple[bytearray, list[int]]] = {}
        self._size = 0  # bytes in the open chunk
        self._chunk_t0: int | None = None
        self._flush_deadline = float("inf")
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._chunk_indexes: list[ChunkIndex] = []
        self._attachment_indexes: list[AttachmentIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._stats = Statistics(message_count=0, schema_count=0, channel_count=0,
                                 attachment_count=0, metadata_count=0, chunk_count=0,
                                 message_start_time=0, message_end_time=0,
                                 channel_message_counts={})
        self._finished = False
        self._worker = ThreadPoolExecutor(1, thread_name_prefix="mcap-chunks") if write_behind else None
        self._written: Future | None = None  # the worker's last chunk
        self._defer_close = defer_close
        self.close_due = False  # a deferred close waits for ``close_if_due``

    # -- lifecycle ------------------------------------------------------------
    def start(self, profile: str = "", library: str = LIBRARY) -> None:
        self._stream.write(MCAP0_MAGIC)
        self._stream.write(_record_bytes(Header(profile=profile, library=library)))
        self._stream.flush()
        self._arm_flush_timer()
        if self._worker is not None:  # its thread starts now, not at the first chunk (~0.5 ms)
            self._worker.submit(int).result()

    def finish(self) -> None:
        """Close the open chunk, write the summary section and the footer."""
        if self._finished:
            return
        self.flush()
        self._wait_written()
        if self._worker is not None:
            self._worker.shutdown()
        self._stream.write(_record_bytes(DataEnd(data_section_crc=0)))
        summary_start = self._stream.tell()
        summary, offsets = self._summary_records(summary_start)
        offsets_start = summary_start + len(summary)
        summary += b"".join(_record_bytes(o) for o in offsets)
        crc = zlib.crc32(summary)
        crc = zlib.crc32(_FOOTER_CRC_PREFIX.pack(Opcode.FOOTER, 20, summary_start, offsets_start), crc)
        self._stream.write(summary)
        self._stream.write(_record_bytes(Footer(summary_start=summary_start,
                                                summary_offset_start=offsets_start,
                                                summary_crc=crc)))
        self._stream.write(MCAP0_MAGIC)
        self._stream.flush()
        self._finished = True

    def _summary_records(self, start: int) -> tuple[bytearray, list[SummaryOffset]]:
        out, offsets = bytearray(), []
        groups = [(Opcode.SCHEMA, self._schemas), (Opcode.CHANNEL, self._channels),
                  (Opcode.STATISTICS, [self._stats]), (Opcode.CHUNK_INDEX, self._chunk_indexes),
                  (Opcode.ATTACHMENT_INDEX, self._attachment_indexes),
                  (Opcode.METADATA_INDEX, self._metadata_indexes)]
        for opcode, records in groups:
            if not records:
                continue
            group_start = start + len(out)
            for record in records:
                out += _record_bytes(record)
            offsets.append(SummaryOffset(group_opcode=opcode, group_start=group_start,
                                         group_length=start + len(out) - group_start))
        return out, offsets

    # -- registration (goes into the open chunk, like mcap's Writer) ---------
    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._stats.schema_count += 1
        self._records += _record_bytes(schema)
        return schema.id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: dict[str, str] | None = None) -> int:
        channel = Channel(id=len(self._channels) + 1, topic=topic, message_encoding=message_encoding,
                          schema_id=schema_id, metadata=dict(metadata or {}))
        self._channels.append(channel)
        self._stats.channel_count += 1
        self._records += _record_bytes(channel)
        return channel.id

    # -- records outside chunks ------------------------------------------------
    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self.flush()
        self._wait_written()
        offset = self._stream.tell()
        raw = _record_bytes(Metadata(name=name, metadata=data))
        self._stream.write(raw)
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=len(raw), name=name))
        self._stats.metadata_count += 1
        self._stream.flush()

    def add_attachment(self, name: str, media_type: str, data: bytes, log_time: int = 0) -> None:
        self.flush()
        self._wait_written()
        offset = self._stream.tell()
        raw = _record_bytes(Attachment(log_time=log_time, create_time=log_time, name=name,
                                       media_type=media_type, data=data))
        self._stream.write(raw)
        self._attachment_indexes.append(AttachmentIndex(
            offset=offset, length=len(raw), log_time=log_time, create_time=log_time,
            data_size=len(data), name=name, media_type=media_type))
        self._stats.attachment_count += 1
        self._stream.flush()

    # -- the hot path ------------------------------------------------------------
    def add_message(self, channel_id: int, log_time: int, data: bytes) -> None:
        """Append one message (log time = publish time, ns) to the open chunk."""
        head = _MESSAGE_HEAD.pack(OP_MESSAGE, MESSAGE_FIELDS.size + len(data), channel_id, 0, log_time, log_time)
        run = self._runs.get(channel_id)  # after the pack: a bad time raises before anything is kept
        if run is None:
            run = self._open_run(channel_id, log_time)
        buf, index = run
        index.append(log_time)
        index.append(len(buf))
        buf += head
        buf += data
        self._size += _MESSAGE_HEAD.size + len(data)
        if (self._size >= self._chunk_size or log_time - self._chunk_t0 >= self._chunk_span_ns
                or time.monotonic() >= self._flush_deadline):
            self._close_when_due(self._size)

    def add_messages(self, channel_id: int, log_times: list[int], payloads: list[bytes]) -> None:
        """Append a batch of one channel's messages to the open chunk, all of them (no chunk closes)."""
        if not log_times:
            return
        head, message, fields_len = _MESSAGE_HEAD.pack, OP_MESSAGE, MESSAGE_FIELDS.size
        heads = [head(message, fields_len + len(data), channel_id, 0, log_time, log_time)
                 for log_time, data in zip(log_times, payloads)]  # a bad time raises before anything is kept
        run = self._runs.get(channel_id)
        buf, index = run if run is not None else self._open_run(channel_id, log_times[0])
        start = len(buf)
        for log_time, record, data in zip(log_times, heads, payloads):
            index.append(log_time)
            index.append(len(buf))
            buf += record
            buf += data
        self._size += len(buf) - start

    def flush_if_due(self, log_time: int, held_bytes: int = 0) -> None:
        """Close the open chunk if ``add_message`` would have: full, spanning ``chunk_span_ns`` by
        ``log_time`` (ns), or the wall-clock flush due (after a batch of ``add_messages``).
        ``held_bytes``: what the caller holds back for this chunk (``before_close`` writes it), counted
        in its size; the wall-clock flush is then due even while the chunk holds nothing yet."""
        if not (self._runs or held_bytes):
            return
        if (self._size + held_bytes >= self._chunk_size or time.monotonic() >= self._flush_deadline
                or (self._chunk_t0 is not None and log_time - self._chunk_t0 >= self._chunk_span_ns)):
            self._close_when_due(self._size + held_bytes)

    def _close_when_due(self, size: int) -> None:
        """The open chunk is due to close: now, or (``defer_close``) at ``close_if_due``."""
        if self._defer_close and size < 2 * self._chunk_size:
            self.close_due = True
        else:
            self.flush()

    def close_if_due(self) -> bool:
        """Close the open chunk if a deferred close is due; True if it did."""
        if not self.close_due:
            return False
        self.flush()
        return True

    def _open_run(self, channel_id: int, log_time: int) -> tuple[bytearray, list[int]]:
        """The open chunk's buffer and index of a channel's first message in it."""
        if self._chunk_t0 is None:
            self._chunk_t0 = log_time
        run = self._runs[channel_id] = (bytearray(), [])
        return run

    def flush(self) -> None:
        """Close the open chunk (if it holds messages) and push it to the OS."""
        self.close_due = False
        if self._before_close is not None:
            self._before_close()
        if self._runs:
            self._write_chunk()
        if self._worker is None:  # the worker flushes what it writes; the stream is its alone
            self._stream.flush()
        self._arm_flush_timer()

    def _arm_flush_timer(self) -> None:
        if self._flush_interval_s is not None:
            self._flush_deadline = time.monotonic() + self._flush_interval_s

    def _write_chunk(self) -> None:
        """Hand the open chunk (its schema/channel records and each channel's messages) to
        ``_store_chunk``: here, or on the write-behind worker, and start an empty one."""
        records, runs = self._records, self._runs
        self._records = bytearray()
        self._runs = {}
        self._size = 0
        self._chunk_t0 = None
        if self._worker is None:
            self._store_chunk(records, runs)
        else:
            self._wait_written(done_only=True)  # an earlier chunk's failure surfaces here
            self._written = self._worker.submit(self._store_chunk, records, runs)

    def _store_chunk(self, records: bytearray, runs: dict[int, tuple[bytearray, list[int]]]) -> None:
        """Write one chunk: ``records`` (schemas, channels), then each channel's messages of
        ``runs`` (channel id -> (records, [t0, offset0, ...])); compressed, with each channel's
        message index after it, counted, and pushed to the OS."""
        parts, base, bases = [records], len(records), {}
        for channel_id, (buf, _) in runs.items():  # each channel's messages after the last's
            bases[channel_id] = base
            parts.append(buf)
            base += len(buf)
        raw = b"".join(parts)
        start = min(min(ix[0::2]) for _, ix in runs.values())
        end = max(max(ix[0::2]) for _, ix in runs.values())
        self._count_chunk(runs, start, end)
        data = self._compressor.compress(raw) if self._compressor else raw
        chunk = Chunk(message_start_time=start, message_end_time=end, uncompressed_size=len(raw),
                      uncompressed_crc=zlib.crc32(raw), compression=self._compression, data=data)
        chunk_offset = self._stream.tell()
        chunk_raw = _record_bytes(chunk)
        self._stream.write(chunk_raw)
        index_offsets, index_raw = {}, bytearray()
        for channel_id, (_, entries) in runs.items():
            index_offsets[channel_id] = chunk_offset + len(chunk_raw) + len(index_raw)
            index_raw += _pack_message_index(channel_id, entries, bases[channel_id])
        self._stream.write(index_raw)
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=start, message_end_time=end,
            chunk_start_offset=chunk_offset, chunk_length=len(chunk_raw),
            message_index_offsets=index_offsets, message_index_length=len(index_raw),
            compression=self._compression, compressed_size=len(data), uncompressed_size=len(raw)))
        self._stream.flush()

    def _wait_written(self, done_only: bool = False) -> None:
        """Wait for the write-behind worker's last chunk (``done_only``: only look whether it
        failed, if it is done); its error, if any, is raised here."""
        written = self._written
        if written is not None and (not done_only or written.done()):
            self._written = None
            written.result()

    def _count_chunk(self, runs: dict, start: int, end: int) -> None:
        stats = self._stats
        first = stats.message_count == 0
        for channel_id, (_, entries) in runs.items():
            n = len(entries) // 2
            stats.channel_message_counts[channel_id] = stats.channel_message_counts.get(channel_id, 0) + n
            stats.message_count += n
        stats.chunk_count += 1
        stats.message_start_time = start if first else min(stats.message_start_time, start)
        stats.message_end_time = max(stats.message_end_time, end)


def _pack_message_index(channel_id: int, entries: list[int], base: int) -> bytes:
    """MessageIndex record: (log time, offset in the uncompressed chunk) pairs; ``entries``' offsets + ``base``."""
    entries = list(entries)
    entries[1::2] = [offset + base for offset in entries[1::2]]
    body = struct.pack(f"<{len(entries)}Q", *entries)
    return _INDEX_HEAD.pack(_OP_MESSAGE_INDEX, 2 + 4 + len(body), channel_id, len(body)) + body
