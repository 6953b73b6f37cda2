"""Fault injection, scheduled from a scenario (docs/design.md, faults).

Every injector returns a list of ``Action``s: the fault's start and, when it
has a duration, its end. The start's dict is its event in /scenario/events
(kind ``fault_<name>``, with the target and ``duration_s``, None meaning to
the end of the run); the end is a ``fault_end`` event naming the fault.

Device faults set the emulated device's fault policy (emulators/device.py:
``silent``, ``frozen``, ``deaf``) or its model (IMU noise, CyberGear fault
bits). Frame faults act on one bus through the rig's ``BusFaults`` of that bus
(hil/bus/frame_faults.py, re-exported here), a stage of the plant's bus end:

- towards the controller (frames the plant sends): drop, delay (late or
  jittered replies), corrupt, error frames after a frame, extra traffic from
  a babbling node, and an arbitration model that makes plant frames wait for
  the wire in CAN priority order and drops them when they wait too long;
- towards the devices (frames the controller sent): drop. Such a frame is
  still in the trace (it left the controller) but no device acts on it.

The rig's lockstep frames (SYNC, Heartbeat) are never touched: they stand
for the controller's clock, not for robot traffic, and without them there
is no run. Random choices come from a generator seeded with the run's seed
and the fault's name and start, so a scenario and seed give the same faults
on every run and the IMU's noise stream is left as it was.
"""
from __future__ import annotations

import zlib
from dataclasses import replace
from typing import Callable

import numpy as np

from wheelleg.controller import constants as C
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.bus.busload import DEFAULT_BITRATE
# BOTH, TO_DEVICES and priority are re-exported: scenarios and tests name them faults.*
from wheelleg.dbc import BUSES  # noqa: F401  (re-exported: scenarios and tests name faults.BUSES)
from wheelleg.hil.bus.frame_faults import (BOTH, TO_CONTROLLER, TO_DEVICES, Arbitration, Babble,  # noqa: F401
                              BusOff, Corrupt, Delay, Drop, ErrorFrames, Garbage, Select,
                              make_select, priority)
from wheelleg.hil.run.scenario import Action


# -- scheduling ---------------------------------------------------------------------
def _window(kind: str, t_s: float, duration_s: float | None, start: Callable, end: Callable | None,
            **fields) -> list[Action]:
    """Start (and end) Actions of one fault; ``start(rig)`` may return extra event fields."""
    if duration_s is not None and not duration_s > 0.0:
        raise ValueError(f"{kind}: duration must be > 0 s or None, got {duration_s!r}")

    def on(rig):
        extra = start(rig) or {}
        return {**fields, "t_s": t_s, "duration_s": duration_s, **extra}

    actions = [Action(t_s, f"fault_{kind}", on)]
    if duration_s is not None and end is not None:
        def off(rig):
            extra = end(rig) or {}
            return {"fault": kind, **fields, **extra}

        actions.append(Action(t_s + duration_s, "fault_end", off))
    return actions


def _device(rig, name: str):
    devices = rig.plant.devices
    if name not in devices:
        raise KeyError(f"no device {name!r}; known: {', '.join(devices)}")
    return devices[name]


# -- device faults ----------------------------------------------------------------------
def _known(device: str, kinds=C.DEVICES) -> str:
    """``device`` if the robot has it (checked when the scenario is defined, not mid-run)."""
    if device not in kinds:
        raise ValueError(f"no device {device!r}; known: {', '.join(kinds)}")
    return device


def _policy(kind: str, flag: str, device: str, t_s: float, duration_s: float | None,
            devices=C.DEVICES) -> list[Action]:
    _known(device, devices)
    return _window(kind, t_s, duration_s, lambda rig: setattr(_device(rig, device), flag, True),
                   lambda rig: setattr(_device(rig, device), flag, False), device=device)


def silent(device: str, t_s: float, duration_s: float | None = None, devices=C.DEVICES) -> list[Action]:
    """``device`` sends nothing from ``t_s`` for ``duration_s`` (unplugged, dead); ``devices``: the
    robot's device names (default: the wheel-legged robot's)."""
    return _policy("silent", "silent", device, t_s, duration_s, devices)


def frozen(device: str, t_s: float, duration_s: float | None = None) -> list[Action]:
    """``device`` repeats its last frame of each kind instead of new data (hung firmware)."""
    return _policy("frozen", "frozen", device, t_s, duration_s)


def esc_hold(wheel: str, t_s: float, duration_s: float | None = None) -> list[Action]:
    """A wheel ESC ignores every command and holds its last current; feedback goes on."""
    if wheel not in {w.name for w in C.WHEELS}:
        raise ValueError(f"esc_hold needs a wheel ({', '.join(w.name for w in C.WHEELS)}), got {wheel!r}")
    return _policy("esc_hold", "deaf", wheel, t_s, duration_s)


def cybergear_fault(joint: str, fault: str, t_s: float) -> list[Action]:
    """A CyberGear latches ``fault`` (wheelleg.dbc.cybergear.FAULT_NAMES); only a clear-fault stop clears it."""
    if fault not in cg.FAULT_NAMES:
        raise ValueError(f"unknown CyberGear fault {fault!r}; expected one of {cg.FAULT_NAMES}")
    _known(joint, tuple(j.name for j in C.JOINTS))
    return _window("cybergear", t_s, None, lambda rig: _device(rig, joint).inject_fault(fault), None,
                   device=joint, fault=fault)


def _imu_noise(kind: str, t_s: float, duration_s: float | None, **changes) -> list[Action]:
    saved = {}

    def start(rig):
        imu = rig.plant.imu
        saved["noise"] = imu.noise
        imu.noise = replace(imu.noise, **changes)

    def end(rig):
        rig.plant.imu.noise = saved["noise"]

    fields = {k: list(v) if isinstance(v, tuple) else v for k, v in changes.items()}
    return _window(kind, t_s, duration_s, start, end, device="imu", **fields)


def imu_bias(t_s: float, duration_s: float | None = None, gyro_bias_rad_s=(0.0, 0.0, 0.0),
             accel_bias_m_s2=(0.0, 0.0, 0.0)) -> list[Action]:
    """Constant offsets on the IMU's rate (rad/s) and specific force (m/s^2), body frame, shape (3,)."""
    return _imu_noise("imu_bias", t_s, duration_s, gyro_bias_rad_s=tuple(map(float, gyro_bias_rad_s)),
                      accel_bias_m_s2=tuple(map(float, accel_bias_m_s2)))


def imu_noise(t_s: float, duration_s: float | None = None, *, gyro_std_rad_s: float,
              accel_std_m_s2: float, attitude_std_rad: float) -> list[Action]:
    """White noise per sample (1 sigma) on rate, specific force and attitude."""
    return _imu_noise("imu_noise", t_s, duration_s, gyro_std_rad_s=gyro_std_rad_s,
                      accel_std_m_s2=accel_std_m_s2, attitude_std_rad=attitude_std_rad)


def imu_spikes(t_s: float, duration_s: float | None = None, *, probability: float,
               magnitude_rad_s: float) -> list[Action]:
    """With ``probability`` per sample one gyro axis is off by +-``magnitude_rad_s``."""
    if not 0.0 <= probability <= 1.0:
        raise ValueError(f"spike probability must be in [0, 1], got {probability!r}")
    return _imu_noise("imu_spikes", t_s, duration_s, spike_probability=probability,
                      spike_rad_s=magnitude_rad_s)


# -- frame faults ------------------------------------------------------------------------
def _frame_fault(kind: str, bus: str, t_s: float, duration_s: float | None, make: Callable,
                 **fields) -> list[Action]:
    """Actions that add the fault ``make(rng)`` to ``bus`` at ``t_s`` and remove it after ``duration_s``.

    The end event reports ``frames_affected``: how many frames the fault
    dropped, delayed, corrupted, followed or sent.
    """
    if bus not in BUSES:
        raise ValueError(f"bus must be one of {BUSES}, got {bus!r}")
    make(np.random.default_rng(0))  # a bad argument fails here, when the scenario is defined
    active = {}

    def start(rig):
        seed = [int(rig.config.seed), zlib.crc32(f"{kind}:{bus}:{t_s!r}".encode())]
        active["fault"] = make(np.random.default_rng(seed))
        rig.bus_faults[bus].add(active["fault"])

    def end(rig):
        rig.bus_faults[bus].remove(active["fault"])
        return {"frames_affected": active["fault"].count}

    return _window(kind, t_s, duration_s, start, end, bus=bus, **fields)


def frame_loss(bus: str, t_s: float, duration_s: float | None, rate: float, *, ids=None, motors=None,
               direction: str = TO_CONTROLLER) -> list[Action]:
    """Each selected frame is lost with probability ``rate`` (towards the controller, the devices or both)."""
    sel = make_select(ids, motors)
    return _frame_fault("frame_loss", bus, t_s, duration_s, lambda rng: Drop(sel, rng, rate, direction),
                        rate=rate, direction=direction, **_fields(sel))


def frame_delay(bus: str, t_s: float, duration_s: float | None, delay_s: float, jitter_s: float = 0.0, *,
                ids=None, motors=None) -> list[Action]:
    """Late (``delay_s``) or jittered (+ U(0, ``jitter_s``)) frames towards the controller."""
    sel = make_select(ids, motors)
    return _frame_fault("frame_delay", bus, t_s, duration_s, lambda rng: Delay(sel, rng, delay_s, jitter_s),
                        delay_s=delay_s, jitter_s=jitter_s, **_fields(sel))


def frame_corruption(bus: str, t_s: float, duration_s: float | None, rate: float, how: str = "bitflip", *,
                     ids=None, motors=None) -> list[Action]:
    """Selected frames towards the controller corrupted with probability ``rate``."""
    sel = make_select(ids, motors)
    return _frame_fault("frame_corruption", bus, t_s, duration_s, lambda rng: Corrupt(sel, rng, rate, how),
                        rate=rate, how=how, **_fields(sel))


def error_frames(bus: str, t_s: float, duration_s: float | None, rate: float) -> list[Action]:
    """An error frame after a frame with probability ``rate``."""
    return _frame_fault("error_frames", bus, t_s, duration_s, lambda rng: ErrorFrames(Select(), rng, rate),
                        rate=rate)


def bus_off(bus: str, t_s: float, duration_s: float | None) -> list[Action]:
    """Nothing crosses ``bus`` either way from ``t_s`` for ``duration_s``."""
    return _frame_fault("bus_off", bus, t_s, duration_s, lambda rng: BusOff(Select(), rng))


def babble(bus: str, t_s: float, duration_s: float | None, load: float, frame_id: int = 0x001,
           extended: bool = False, bitrate: int = DEFAULT_BITRATE) -> list[Action]:
    """A babbling node: ``frame_id`` frames (8 bytes) using ``load`` of the bus capacity."""
    return _frame_fault("babble", bus, t_s, duration_s,
                        lambda rng: Babble(Select(), rng, load, frame_id, extended, bitrate),
                        load=load, frame_id=frame_id, extended=extended)


def garbage(bus: str, t_s: float, duration_s: float | None, frames_per_s: float) -> list[Action]:
    """A faulty node on ``bus`` sending ``frames_per_s`` malformed or unknown frames (``Garbage``)."""
    return _frame_fault("garbage", bus, t_s, duration_s, lambda rng: Garbage(Select(), rng, bus, frames_per_s),
                        frames_per_s=frames_per_s)


def arbitration(bus: str, t_s: float = 0.0, duration_s: float | None = None, max_wait_s: float = 0.005,
                bitrate: int = DEFAULT_BITRATE) -> list[Action]:
    """Plant frames contend for the wire in priority order; after ``max_wait_s`` they are dropped."""
    return _frame_fault("arbitration", bus, t_s, duration_s,
                        lambda rng: Arbitration(Select(), rng, bitrate, max_wait_s),
                        max_wait_s=max_wait_s, bitrate=bitrate)


def _fields(sel: Select) -> dict:
    return {"ids": None if sel.ids is None else sorted(sel.ids),
            "motors": None if sel.motors is None else sorted(sel.motors)}
