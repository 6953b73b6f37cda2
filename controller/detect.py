"""Offline detection, after the design document's detect_task (docs/control.md).

Every device has an offline threshold and a warning level. Each tick the
highest level among the offline devices and their number are found (the document
turns them into buzzer and RGB patterns; here they go into the heartbeat).
All devices start offline, as in detect_device_init().
"""
from __future__ import annotations

import collections
import math
from dataclasses import dataclass
from typing import NamedTuple

from wheelleg.controller import constants as C


@dataclass(frozen=True)
class DeviceRule:
    name: str
    offline_after_s: float  # s without a good frame before the device is offline
    warning_level: int  # 1 (least) .. 5 (worst); what the heartbeat reports
    needed_for_balance: bool  # offline -> disable the motors


# Thresholds: a few periods of each device's frame rate (joints answer every
# 2 ms command, ESCs send at 1 kHz, the IMU at 500 Hz, the remote at 50 Hz),
# in the range of DJI's detect_task.c and the HNU daemon (docs/control.md).
RULES = tuple(
    [DeviceRule(j.name, 0.020, 4, True) for j in C.JOINTS]
    + [DeviceRule(w.name, 0.010, 4, True) for w in C.WHEELS]
    + [DeviceRule("imu", 0.010, 5, True), DeviceRule("remote", 0.100, 2, True)]
)
assert tuple(r.name for r in RULES) == C.DEVICES


# Times are tick multiples in float: a gap of exactly the threshold must count
# as offline whatever the rounding (1.01 - 1.0 is 0.010000000000000009).
_ROUNDING_S = 1e-9


class Report(NamedTuple):
    offline_mask: int  # bit i set: RULES[i] offline or reporting a fault
    offline_count: int  # devices offline or faulted
    warning_level: int  # highest level among them, 0 when all is well
    balance_ok: bool  # no device the balance needs is offline or faulted


def check(last_seen_s: dict[str, float], now_s: float, faulted=frozenset(), rules=RULES) -> Report:
    """Which devices are offline at ``now_s`` given when each was last heard (s).

    A device named in ``faulted`` (a CyberGear reporting fault bits, a C620
    latched by ``EscWatch``) counts as offline: the design document's detect task flags a device whose data is in error
    the same way as one that went silent (``error_exist``). ``rules`` are the
    robot's devices (default: the wheel-legged robot's ``RULES``); bit i of the
    mask is ``rules[i]``.
    """
    mask = count = level = 0
    balance_ok = True
    for bit, name, offline_after_s, warning_level, needed in _table(rules):
        if name in faulted or now_s - last_seen_s.get(name, _NEVER) >= offline_after_s:
            mask |= bit
            count += 1
            level = warning_level if warning_level > level else level  # max(level, warning_level)
            balance_ok = balance_ok and not needed
    return Report(mask, count, level, balance_ok)


_NEVER = -math.inf  # s, when a device never heard was last heard


_TABLES: dict[int, tuple] = {}  # id(rules) -> (rules, their table): the rules kept, so no id is reused


def _table(rules) -> tuple:
    """``rules`` as ``check`` reads them every tick: (mask bit, name, s silent that is offline
    less the rounding slack, warning level, needed for balance) per rule, worked out once a
    rule set (found by identity: hashing the rules' dataclasses cost more than the check)."""
    kept = _TABLES.get(id(rules))
    if kept is None or kept[0] is not rules:
        table = tuple((1 << bit, rule.name, rule.offline_after_s - _ROUNDING_S, rule.warning_level,
                       rule.needed_for_balance) for bit, rule in enumerate(rules))
        kept = _TABLES[id(rules)] = (rules, table)
    return kept[1]


class ReenableRequest:
    """The operator's Reenable press, remembered for ``window_s`` (s) while the motors are off.

    One press must both clear a latched CyberGear fault (the clear-fault stop
    goes out on the press's tick, the clean reply comes a tick later) and
    enable; a press made while the motors run is not remembered, so it can
    never re-enable after a later fault.
    """

    def __init__(self, window_s: float):
        self.window_s = window_s
        self._until_s = float("-inf")

    def update(self, pressed: bool, motors_off: bool, now_s: float) -> bool:
        """Take this tick's press (an edge); True while a press is pending."""
        if pressed and motors_off:
            self._until_s = now_s + self.window_s
        return self.pending(now_s)

    def pending(self, now_s: float) -> bool:
        return now_s <= self._until_s

    def consume(self) -> None:
        """The motors were enabled: the press is spent."""
        self._until_s = float("-inf")


def esc_follows(commanded_a, reported_a: float, speed_rad_s: float, tolerance_a: float,
                back_emf_fraction: float) -> bool:
    """Whether a C620's reported current (A) is what it was told within ``tolerance_a``.

    ``commanded_a`` is the recent commands (A, newest last) the feedback may be
    answering (feedback latency): the report must lie within their range widened
    by the tolerance. Driving near the no-load speed the back-EMF caps the
    current the ESC can reach, so there (same sign as the speed, above
    ``back_emf_fraction`` of the no-load speed, rad/s) any current counts as following.
    """
    low, high = min(commanded_a), max(commanded_a)
    if abs(speed_rad_s) > back_emf_fraction * C.M3508_NO_LOAD_SPEED and (
            commanded_a[-1] * speed_rad_s > 0.0):
        return True
    return low - tolerance_a <= reported_a <= high + tolerance_a


class EscWatch:
    """A C620 that does not do what it is told (hung, holding its last current): a latched fault.

    ``update`` compares the current reported now with the commands of the last
    ``window`` ticks (the feedback answers the one before, or an earlier one when
    it is late); a mismatch that lasts ``hold_s`` latches the fault, as a CyberGear
    latches its fault bits: a hung ESC spinning its wheel up to no-load speed
    reports no current (back-EMF) and would look well again. ``clear`` (the
    operator's Reenable) unlatches it.
    """

    def __init__(self, tolerance_a: float, hold_s: float, back_emf_fraction: float, window: int = 1):
        self.tolerance_a, self.hold_s, self.back_emf_fraction = tolerance_a, hold_s, back_emf_fraction
        self._commands: collections.deque = collections.deque([0.0], maxlen=max(1, window))
        self._since_s: float | None = None
        self.latched = False

    def commanded(self, current_a: float) -> None:
        """The current (A) sent this tick: the feedback of the next ticks answers it."""
        self._commands.append(current_a)

    def update(self, reported_a: float, speed_rad_s: float, now_s: float) -> bool:
        """True while the fault is latched."""
        if esc_follows(tuple(self._commands), reported_a, speed_rad_s, self.tolerance_a, self.back_emf_fraction):
            self._since_s = None
        else:
            self._since_s = now_s if self._since_s is None else self._since_s
            self.latched = self.latched or now_s - self._since_s >= self.hold_s - _ROUNDING_S
        return self.latched

    def clear(self) -> None:
        self.latched, self._since_s = False, None
