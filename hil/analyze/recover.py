"""An indexed copy of a trace whose writer was killed.

A killed run's trace ends at its last complete chunk, without the summary
section: stream readers take it, mcap's indexed readers (Python
``make_reader(...).iter_messages``, TypeScript ``McapIndexedReader``, the
Foxglove app's seek) do not. ``recover`` reads every record that survived,
in file order, and writes them again through mcap's own writer, which
finishes with the summary, the chunk indexes and the footer.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mcap.records import Attachment, Channel, Message, Metadata, Schema
from mcap.writer import CompressionType, Writer

from wheelleg.hil.record.mcap_read import RecordScan, read_records


@dataclass(frozen=True)
class Recovered:
    """What ``recover`` kept: counts of messages, channels, metadata and attachments; the input's state."""

    out: Path
    messages: int
    channels: int
    metadata: int
    attachments: int
    was_complete: bool  # the input had its footer already (the copy is then just re-indexed)
    stopped_at: str  # why reading the input stopped early ("" when it did not)


def recover(trace: Path, out: Path) -> Recovered:
    """Write ``out``: every record of ``trace`` that survived, with a summary and index."""
    scan = RecordScan()
    counts = {"messages": 0, "channels": 0, "metadata": 0, "attachments": 0}
    with open(out, "wb") as f:
        writer = Writer(f, compression=CompressionType.ZSTD)
        writer.start(profile="", library="wheelleg-hil recover")
        schemas: dict[int, int] = {}  # input schema id -> output schema id
        channels: dict[int, int] = {}  # input channel id -> output channel id
        for record in read_records(trace, scan):
            if isinstance(record, Schema):
                schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
            elif isinstance(record, Channel) and record.id not in channels:
                channels[record.id] = writer.register_channel(record.topic, record.message_encoding,
                                                              schemas.get(record.schema_id, 0), record.metadata)
                counts["channels"] += 1
            elif isinstance(record, Message) and record.channel_id in channels:
                writer.add_message(channels[record.channel_id], record.log_time, record.data,
                                   record.publish_time, record.sequence)
                counts["messages"] += 1
            elif isinstance(record, Metadata):
                writer.add_metadata(record.name, dict(record.metadata))
                counts["metadata"] += 1
            elif isinstance(record, Attachment):
                writer.add_attachment(record.create_time, record.log_time, record.name, record.media_type,
                                      record.data)
                counts["attachments"] += 1
        writer.finish()
    return Recovered(out, **counts, was_complete=scan.complete, stopped_at=scan.error or "")
