"""One recorded CAN frame: the record every reader and writer of the rig uses.

The recorder makes one per frame the plant sees (``Frame.of``), the MCAP and
candump sinks write it, ``TraceReader``, ``CandumpReader`` and
``open_recording`` give it back. Time is integer nanoseconds of bus time.
"""
from __future__ import annotations

from dataclasses import dataclass

import can
import numpy as np


@dataclass(slots=True)
class Frame:
    """One CAN frame at bus time ``t_ns``.

    ``channel`` is the interface name as recorded ("vcan0"), ``bus`` its role
    ("can1" wheels/IMU/remote, "can2" joints; "" while unknown). ``dlc``: the
    data length, the requested length of a remote frame, or a raw DLC 9..15 of
    a classic 8-byte frame. An error frame's ``arbitration_id`` holds its error
    class bits. ``direction`` is candump's "R"/"T" when the log carries it,
    ``line_no`` the candump line (0 for MCAP). Not frozen (a frozen dataclass
    costs 5x more to make, and the recorder makes one per frame): treat it as
    a value and use ``dataclasses.replace`` for a changed copy.
    """

    t_ns: int
    channel: str
    arbitration_id: int
    is_extended: bool
    data: bytes
    dlc: int
    bus: str = ""
    is_error: bool = False
    is_remote: bool = False
    is_fd: bool = False
    fd_flags: int = 0
    direction: str = ""
    line_no: int = 0

    @classmethod
    def of(cls, msg: can.Message, channel: str, t_ns: int, bus: str = "") -> "Frame":
        """The frame python-can's ``msg`` stands for, on ``channel`` at ``t_ns``."""
        return cls(t_ns, channel, msg.arbitration_id, msg.is_extended_id, bytes(msg.data[:msg.dlc]), msg.dlc,
                   bus, msg.is_error_frame, msg.is_remote_frame, msg.is_fd)

    def message(self) -> can.Message:
        """The frame as python-can delivers it to the controller."""
        return can.Message(timestamp=self.t_ns / 1e9, arbitration_id=self.arbitration_id,
                           is_extended_id=self.is_extended, dlc=self.dlc, data=self.data,
                           is_error_frame=self.is_error, is_remote_frame=self.is_remote,
                           is_fd=self.is_fd, channel=self.channel, check=False)

    def where(self) -> str:
        """'line 12' for a log, 't=1.234567 s' for a trace."""
        return f"line {self.line_no}" if self.line_no else f"t={self.t_ns / 1e9:.6f} s"


@dataclass
class FrameColumns:
    """One channel's frames by column, in time order (``TraceReader.frame_columns``): what
    readers that judge every frame of a bus at once (checks, derived signals) need,
    without a ``Frame`` object each. Arrays have shape (n,)."""

    t_ns: np.ndarray  # int64, bus time (ns)
    arbitration_id: np.ndarray  # int64
    is_extended: np.ndarray  # bool
    is_error: np.ndarray  # bool
    data: list[bytes]  # each frame's payload

    @classmethod
    def of(cls, frames: list[Frame]) -> "FrameColumns":
        return cls(np.array([f.t_ns for f in frames], dtype=np.int64),
                   np.array([f.arbitration_id for f in frames], dtype=np.int64),
                   np.array([f.is_extended for f in frames], dtype=bool),
                   np.array([f.is_error for f in frames], dtype=bool), [f.data for f in frames])

    ARRAYS = ("t_ns", "arbitration_id", "is_extended", "is_error")  # its (n,) arrays, in field order

    @classmethod
    def joined(cls, parts: list["FrameColumns"]) -> "FrameColumns":
        if not parts:
            return cls.of([])
        return cls(*(np.concatenate([getattr(p, name) for p in parts]) for name in cls.ARRAYS),
                   [d for p in parts for d in p.data])

    def frozen(self) -> "FrameColumns":
        """These columns with their arrays made read-only (in place): for columns shared by readers."""
        for name in self.ARRAYS:
            getattr(self, name).flags.writeable = False
        return self
