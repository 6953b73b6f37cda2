"""Offline detection, after seed 000's detect_task.

Every device has an offline threshold and a warning level. Each tick the
highest level among the offline devices and their number are found (the seed
turns them into buzzer and RGB patterns; here they go into the heartbeat).
All devices start offline, as in detect_device_init().
"""
from __future__ import annotations

from dataclasses import dataclass

from controller import constants as C


@dataclass(frozen=True)
class DeviceRule:
    name: str
    offline_after_s: float  # s without a good frame before the device is offline
    warning_level: int  # 1 (least) .. 5 (worst); what the heartbeat reports
    needed_for_balance: bool  # offline -> disable the motors


# Thresholds: a few periods of each device's frame rate (joints answer every
# 2 ms command, ESCs send at 1 kHz, the IMU at 500 Hz, the remote at 50 Hz),
# in the range of DJI's detect_task.c and the HNU daemon (control_notes §1.10).
RULES = tuple(
    [DeviceRule(j.name, 0.020, 4, True) for j in C.JOINTS]
    + [DeviceRule(w.name, 0.010, 4, True) for w in C.WHEELS]
    + [DeviceRule("imu", 0.010, 5, True), DeviceRule("remote", 0.100, 2, True)]
)
assert tuple(r.name for r in RULES) == C.DEVICES


@dataclass(frozen=True)
class Report:
    offline_mask: int  # bit i set: RULES[i] offline
    offline_count: int
    warning_level: int  # highest level among the offline devices, 0 when all online
    balance_ok: bool  # no device the balance needs is offline


def check(last_seen_s: dict[str, float], now_s: float) -> Report:
    """Which devices are offline at ``now_s`` given when each was last heard."""
    mask = count = level = 0
    balance_ok = True
    for bit, rule in enumerate(RULES):
        if now_s - last_seen_s.get(rule.name, float("-inf")) > rule.offline_after_s:
            mask |= 1 << bit
            count += 1
            level = max(level, rule.warning_level)
            balance_ok = balance_ok and not rule.needed_for_balance
    return Report(mask, count, level, balance_ok)
