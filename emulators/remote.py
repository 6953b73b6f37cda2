"""The operator's remote: sends rig.dbc's Operator frame on CAN1 at 50 Hz.

The scenario (or a person) sets what the remote asks; the frame goes out
every ``period_s`` whatever changes, as a radio receiver bridged onto CAN
would. ``silent`` models the remote dropping out. Another robot's remote is
the same node with its own message and starting signals (the quadruped's
QuadOperator, emulators/quadruped/plant.py).
"""
from __future__ import annotations

import can

from wheelleg.dbc import CAN1, load_bus
from wheelleg.emulators.device import EmulatedDevice, PeriodicSchedule

_OPERATOR = load_bus(CAN1).get_message_by_name("Operator")


class Remote(EmulatedDevice):
    """A CAN node that only talks: its message (default: the Operator frame), periodically.

    ``command``: the message's signals (name -> SI value) it starts with; every
    signal of ``message`` must be there.
    """

    def __init__(self, period_s: float = 0.02, message=None, command: dict | None = None):
        super().__init__()
        self._schedule = PeriodicSchedule(period_s)
        self._message = _OPERATOR if message is None else message
        self.command = dict(command) if command is not None else {
            "Mode": 0, "Jump": 0, "JumpForward": 0, "Reenable": 0, "SpeedX": 0.0,
            "YawRate": 0.0, "LegLength": 0.17, "Pitch": 0.0, "Roll": 0.0}
        missing = {s.name for s in self._message.signals} - set(self.command)
        if missing:
            raise ValueError(f"the remote's {self._message.name} needs a start value for {sorted(missing)}")

    def set(self, **signals) -> None:
        """Change what the remote asks, by signal name of its message (SI units)."""
        unknown = set(signals) - set(self.command)
        if unknown:
            raise ValueError(f"not {self._message.name} signals: {sorted(unknown)}")
        self.command.update(signals)

    listens = False  # its node skips it when a frame comes (``_handle`` for a direct caller)

    def _handle(self, msg: can.Message, now_s: float) -> list[can.Message]:
        return []  # a remote listens to nobody

    def _periodic(self, now_s: float) -> list[can.Message]:
        if not self._schedule.due(now_s):
            return []
        data = self._message.encode(self.command, strict=False)
        return [can.Message(arbitration_id=self._message.frame_id, data=data, is_extended_id=False,
                            timestamp=now_s, check=False)]

    def output_torque(self, now_s: float) -> float:
        return 0.0
