"""``wheelleg export``: a copy of a trace with the ``/decoded/<channel>/<Message>`` topics, for Foxglove.

A run's trace keeps raw frames only (``/can/<channel>``); readers derive the
DBC signals (``wheelleg.hil.record.derived``). Foxglove plots what a file
holds, so ``export_decoded`` writes every record of the trace again (metadata,
attachments, each topic's messages byte for byte) plus one JSON message per
decodable frame on ``/decoded/<channel>/<Message>``, decoded by the trace's own
DBC attachments: the topics, schemas and records a run recorded with
``--decoded`` (``RigConfig(decode=True)``) has.
"""
from __future__ import annotations

import heapq
from dataclasses import dataclass
from pathlib import Path

from wheelleg.hil.record.sources import TraceError
from wheelleg.hil.record.trace import CAN_PREFIX, DECODED_PREFIX, TraceReader, TraceWriter

_BATCH = 1024  # frames handed to the writer at a time


@dataclass(frozen=True)
class Exported:
    """What ``export_decoded`` wrote: frames, decoded messages, other messages copied; the input's state."""

    out: Path
    frames: int
    decoded: int
    copied: int
    truncated: bool


def export_decoded(trace: Path, out: Path) -> Exported:
    """Write ``out``: ``trace``'s records with its frames' ``/decoded/`` topics added (TraceError if it cannot)."""
    try:
        reader = TraceReader(trace)
    except Exception as exc:  # a file that is not MCAP past its magic
        raise TraceError(f"{trace}: not a readable MCAP trace: {exc}") from exc
    if not reader.decodes:
        raise TraceError(f"{trace}: its run record names no CAN channels, so its frames cannot be given a "
                         "bus's DBC (a trace of the rig's runs can)")
    attachments = [(name, data, reader.attachment_media_types.get(name, "application/octet-stream"))
                   for name, data in reader.attachments.items()]
    writer = TraceWriter(out, metadata=reader.metadata, attachments=attachments, dbs=reader.dbs, decode=True,
                         flush_interval_s=None)
    frames = copied = 0
    with writer:
        streams = [((f.t_ns, 0, None, f) for f in reader.frames())]
        for topic in reader.topics:
            if not topic.startswith((CAN_PREFIX, DECODED_PREFIX)):  # /decoded/ is written again from the frames
                channel_id = writer.copy_channel(topic, *reader.schema(topic))  # as stored
                streams.append(_tagged(reader.records(topic), channel_id))
        batch = []
        for t_ns, _, channel_id, item in heapq.merge(*streams, key=lambda r: r[:2]):
            if channel_id is None:  # a frame: to the writer a batch at a time (its /can/ and /decoded/ records)
                batch.append(item)
                if len(batch) < _BATCH:
                    continue
            if batch:
                writer.on_frames(batch)
                frames, batch = frames + len(batch), []
            if channel_id is not None:
                writer.copy(channel_id, t_ns, item)
                copied += 1
        if batch:
            writer.on_frames(batch)
            frames += len(batch)
    decoded = sum(n for topic, n in TraceReader(out).topics.items() if topic.startswith(DECODED_PREFIX))
    return Exported(out, frames, decoded, copied, reader.truncated)


def _tagged(records: list[tuple[int, bytes]], channel_id: int):
    """(t_ns, 1, channel id, record) for each stored record: after a frame of the same time."""
    return ((t_ns, 1, channel_id, data) for t_ns, data in records)
