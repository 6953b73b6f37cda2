"""The rig's MCAP trace as a python-can log format (``.mcap``).

Registered under python-can's entry-point groups ``can.io.message_reader``
and ``can.io.message_writer`` (pyproject.toml), so ``can.LogReader``,
``can.Logger``, ``python -m can.player`` and ``python -m can.logconvert``
take a trace: the reader yields every ``/can/<channel>`` frame merged by bus
time (``msg.channel`` the interface name); the writer records what it is
given as a trace of raw frames (no run metadata: it did not come from a run).
"""
from __future__ import annotations

from typing import Any, Iterator

import can
from can.io.generic import MessageReader, MessageWriter

from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.trace import TraceReader, TraceWriter

DEFAULT_CHANNEL = "can0"  # a message without a channel is recorded on this one


class McapReader(MessageReader):
    """Every CAN frame of a trace (complete or cut off), in bus-time order."""

    def __init__(self, file, **kwargs: Any) -> None:
        self.trace = TraceReader(file)

    def __iter__(self) -> Iterator[can.Message]:
        for frame in self.trace.frames():
            yield frame.message()

    def stop(self) -> None:
        """Nothing to release: the trace was read whole."""


class McapWriter(MessageWriter):
    """A trace of the frames it receives; ``stop`` writes the summary (an indexed file)."""

    def __init__(self, file, **kwargs: Any) -> None:
        self.trace = TraceWriter(file, metadata={}, flush_interval_s=None).start()

    def on_message_received(self, msg: can.Message) -> None:
        channel = DEFAULT_CHANNEL if msg.channel is None else str(msg.channel)
        self.trace.frame(Frame.of(msg, channel, round(msg.timestamp * 1e9)))

    def stop(self) -> None:
        self.trace.finish()
