"""Schemas of the trace's channels: ROS 2 message definitions (CDR) and JSON Schemas.

Foxglove reads these to list and plot fields. In the JSON channels every numeric
field is a JSON number and carries its unit in ``description``; values that are
not finite (NaN, inf) are written as ``null``: JSON has no NaN.

Topics (the trace contract, docs/design.md):
- ``/can/<channel>``: one binary message per bus and 100 ms window of bus time holding its
  frames (``CAN_FRAMES_MSG``; older traces: one per frame, ``CAN_FRAME_MSG``, or JSON,
  ``CAN_FRAME_JSON``).
- ``/decoded/<channel>/<Message>``: only in an export or with ``--decoded``: the DBC signals
  of one frame (``decoded_schema``), plus the CyberGear fields that live in the 29-bit id.
- ``/sim/state``: simulation ground truth each control period, one float64 per field
  (``hil/record/float_records.py``; the fields, units and notes: ``sim_state_schema``; older
  traces: JSON with that schema).
- ``/controller/debug``: the controller's internals, float64 each (the robot's ``debug_schema``
  names the fields; older traces: JSON).
- ``/scenario/events``: ``{"kind": ..., ...}`` (``EVENT``).
- ``/bus/load``: each bus's load per 100 ms window (``BUS_LOAD``).
- anything else: a generic JSON channel (``inferred_schema`` or the caller's).
"""
from __future__ import annotations

import json
import struct
from typing import Any

CAN_PREFIX, DECODED_PREFIX = "/can/", "/decoded/"  # + channel; + channel/message
SIM_STATE_TOPIC, EVENTS_TOPIC = "/sim/state", "/scenario/events"
NUMBER_OR_NULL = ["number", "null"]

# /can/<channel>: binary, ROS 2 message definition (schema encoding "ros2msg",
# message encoding "cdr"), so Foxglove plots ``data[i]`` as numbers and mcap's
# ROS 2 decoder (mcap-ros2-support) reads it. A record is 16 bytes + the payload
# (``CAN_FRAME_HEAD``): the 4-byte CDR header (little endian), id, extended,
# dlc, error, one byte of padding, the payload's length, the payload.
CAN_FRAME_NAME = "wheelleg/msg/CanFrame"
CAN_FRAME_ENCODING, CAN_FRAME_MESSAGE_ENCODING = "ros2msg", "cdr"
CAN_FRAME_MSG = """\
# One CAN frame as it crossed the bus; log time = bus time (ns).
uint32 id  # arbitration id (11 or 29 bit); error class bits for error frames
bool extended  # 29-bit identifier
uint8 dlc  # data length code
bool error  # error frame
uint8[] data  # payload
"""
CAN_FRAME_HEAD = struct.Struct("<4sIBBBxI")  # CDR header, id, extended, dlc, error, pad, len(data)
CDR_LE = b"\x00\x01\x00\x00"

# /can/<channel> since the batched records: one message per bus and window of bus time
# (100 ms; log time = its first frame's), the frames as parallel arrays (hil/record/can_batch.py
# packs and reads them). Traces with CAN_FRAME_NAME (one message per frame) read as before.
CAN_FRAMES_NAME = "wheelleg/msg/CanFrames"
CAN_FRAMES_MSG = """\
# The CAN frames of one bus in one window of bus time, in bus-time order; log time = the first one's.
uint32[] gap_ns  # each frame's bus time (end of its transmission) after the previous one's (the first: 0), ns
uint32[] id  # arbitration id (11 or 29 bit); error class bits for an error frame
uint8[] flags  # bit 0 extended (29-bit id), 1 error frame, 2 remote frame, 3 CAN FD; bits 4-6 the FD flags
uint8[] dlc  # data length code (a remote frame's requested length)
uint8[] length  # payload bytes of each frame
uint8[] data  # the payloads, one after another (frame i's: length[i] bytes after the previous ones)
"""

# /can/<channel> of traces recorded before the binary records (JSON, read back by TraceReader).
CAN_FRAME_JSON: dict = {
    "title": "wheelleg.CanFrame",
    "description": "One CAN frame as it crossed the bus; log time = bus time (ns).",
    "type": "object",
    "properties": {
        "id": {"type": "integer", "minimum": 0, "maximum": 0x1FFFFFFF,
               "description": "arbitration id (11 or 29 bit); error class bits for error frames"},
        "extended": {"type": "boolean", "description": "29-bit identifier"},
        "dlc": {"type": "integer", "minimum": 0, "maximum": 64, "description": "data length code"},
        "data": {"type": "string", "pattern": "^([0-9a-f]{2})*$", "description": "payload, hex"},
        "error": {"type": "boolean", "description": "error frame"},
    },
    "required": ["id", "extended", "dlc", "data", "error"],
    "additionalProperties": False,
}

# /sim/state: field -> unit. Order is the order of the trace contract: every robot's body pose
# (POSE_FIELDS), then its own (SIM_STATE_FIELDS: the wheel-legged robot's; another robot's in its
# registry entry, wheelleg.hil.robots).
POSE_FIELDS: dict[str, str] = {
    "t": "s",
    "x": "m", "y": "m", "z": "m",
    "roll": "rad", "pitch": "rad", "yaw": "rad",
    "vx": "m/s", "vy": "m/s", "vz": "m/s",
    "wx": "rad/s", "wy": "rad/s", "wz": "rad/s",
}
SIM_STATE_FIELDS: dict[str, str] = {
    **POSE_FIELDS,
    "left_leg_length": "m", "right_leg_length": "m",
    "left_leg_angle": "rad", "right_leg_angle": "rad",
    "left_normal_force": "N", "right_normal_force": "N",
}
# Fields Physics.ground_truth adds beyond the contract (optional in the schema, so
# a trace from another plant still validates); the airborne checks read them.
SIM_STATE_EXTRA_FIELDS: dict[str, str] = {
    "body_on_ground": "", "left_wheel_clearance": "m", "right_wheel_clearance": "m",
}
_SIM_STATE_NOTES = {
    "t": "simulated time", "x": "body position, world frame", "roll": "body attitude",
    "vx": "body velocity, world frame", "wx": "body angular velocity, body frame",
    "left_leg_length": "five-bar virtual leg length L0", "left_leg_angle": "virtual leg angle phi0",
    "left_normal_force": "wheel-floor normal force",
    "body_on_ground": "1 when the body box touches the ground, else 0",
    "left_wheel_clearance": "lowest wheel point above the ground below it (< 0 pressed in)",
    "right_wheel_clearance": "lowest wheel point above the ground below it (< 0 pressed in)",
    "height": "body centre above the mean of the feet's centres (the hip plane above the feet)",
    **{f"{leg}_foot_force": "foot-floor normal force" for leg in ("FR", "FL", "RR", "RL")},
    **{f"{leg}_foot_z": "foot centre's height, world frame" for leg in ("FR", "FL", "RR", "RL")},
}

EVENT: dict = {
    "title": "wheelleg.ScenarioEvent",
    "description": "A scenario event (push, fault, operator command, deadline miss...).",
    "type": "object",
    "properties": {"kind": {"type": "string", "description": "what happened"}},
    "required": ["kind"],
    "additionalProperties": True,
}


BUS_LOAD: dict = {
    "title": "wheelleg.BusLoad",
    "description": "Load of one CAN bus over one window of simulated time (wheelleg.hil.bus.busload.LoadMeter).",
    "type": "object",
    "properties": {
        "channel": {"type": "string", "description": "interface name (vcan0 ...)"},
        "window_start_s": {"type": "number", "description": "[s] simulated time the window starts"},
        "window_s": {"type": "number", "description": "[s] window length"},
        "load": {"type": "number", "minimum": 0,
                 "description": "[s/s] wire time of the window's frames (stuff bits included) / window; "
                                "above 1: demand beyond the bus capacity"},
        "frames": {"type": "integer", "minimum": 0, "description": "frames put on the bus in the window"},
        "frames_per_s": {"type": "number", "description": "[1/s] frame rate over the window"},
    },
    "required": ["channel", "window_start_s", "window_s", "load", "frames", "frames_per_s"],
    "additionalProperties": False,
}


def _number(unit: str, note: str = "") -> dict:
    text = f"[{unit}] {note}".strip() if unit else note
    return {"type": NUMBER_OR_NULL, "description": text} if text else {"type": NUMBER_OR_NULL}


def sim_state_schema(extra_fields: list[str] = (), fields: dict[str, str] | None = None) -> dict:
    """Schema of ``/sim/state``: the contract's ``fields`` (name -> unit; default: the wheel-legged
    robot's, ``SIM_STATE_FIELDS``) plus ``extra_fields`` (numbers)."""
    fields = SIM_STATE_FIELDS if fields is None else fields
    props = {name: _number(unit, _SIM_STATE_NOTES.get(name, "")) for name, unit in fields.items()}
    for name in extra_fields:
        props.setdefault(name, _number(SIM_STATE_EXTRA_FIELDS.get(name, ""), _SIM_STATE_NOTES.get(name, "")))
    return {
        "title": "wheelleg.SimState",
        "description": "Simulation ground truth (never seen by the controller), SI units.",
        "type": "object",
        "properties": props,
        "required": list(fields),
        "additionalProperties": {"type": NUMBER_OR_NULL},
    }


def _signal_property(signal) -> dict:
    prop = _number(signal.unit or "", (signal.comment or "").strip())
    if signal.choices:
        names = ", ".join(f"{int(k)}={v}" for k, v in sorted(signal.choices.items()))
        prop["description"] = (prop.get("description", "") + f" choices: {names}").strip()
    return prop


def decoded_schema(message, id_fields: dict[str, str] | None = None, payload_optional: bool = False) -> dict:
    """Schema of ``/decoded/<channel>/<message.name>`` for a cantools message.

    ``id_fields`` maps the names of fields read from the identifier (CyberGear)
    to their unit. The signals are required unless the message is multiplexed
    (a frame carries only the signals of its multiplexer value) or
    ``payload_optional`` (some frames of the topic carry no payload: type-0 requests).
    """
    props = {s.name: _signal_property(s) for s in message.signals}
    for name, unit in (id_fields or {}).items():
        props[name] = _number(unit, "from the 29-bit identifier")
    required = [] if message.is_multiplexed() or payload_optional else [s.name for s in message.signals]
    return {
        "title": f"wheelleg.decoded.{message.name}",
        "description": (message.comment or message.name).strip(),
        "type": "object",
        "properties": props,
        "required": required,
        "additionalProperties": False,
    }


def described_schema(title: str, fields: dict[str, str]) -> dict:
    """A JSON channel of numbers whose every field has a description (meaning and unit)."""
    return {"title": title, "type": "object",
            "properties": {k: {"type": ["number", "null"], "description": text} for k, text in fields.items()},
            "required": list(fields), "additionalProperties": False}


def inferred_schema(title: str, payload: dict) -> dict:
    """A permissive schema for a generic JSON channel, typed from its first payload."""
    return {"title": title, "type": "object",
            "properties": {k: _infer(v) for k, v in payload.items()},
            "additionalProperties": True}


def _infer(value: Any) -> dict:
    if isinstance(value, bool):
        return {"type": "boolean"}
    if isinstance(value, (int, float)) or value is None:
        return {"type": NUMBER_OR_NULL}
    if isinstance(value, str):
        return {"type": "string"}
    if isinstance(value, dict):
        return {"type": "object", "properties": {k: _infer(v) for k, v in value.items()}}
    if isinstance(value, (list, tuple)):
        return {"type": "array"}
    return {}


def schema_bytes(schema: dict) -> bytes:
    """Canonical JSON text of a schema (sorted keys: the same schema, the same bytes)."""
    return json.dumps(schema, sort_keys=True, separators=(",", ":")).encode()


CONTROLLER_TIMING: dict = {
    "title": "wheelleg.ControllerTiming",
    "description": "Real-time mode: one free-running controller tick, timed on the wall clock "
                   "(hil/run/loop_timing.py); log time = tick x control period.",
    "type": "object",
    "properties": {
        "tick": {"type": "integer", "minimum": 0, "description": "tick number (floor of controller time / period)"},
        "start_s": {"type": "number", "description": "[s] wall time of the tick's start since the first tick"},
        "period_s": {"type": "number", "description": "[s] wall time since the previous tick's start"},
        "jitter_s": {"type": "number", "description": "[s] period_s minus the nominal control period"},
        "missed": {"type": "integer", "minimum": 0,
                   "description": "periods before this tick in which no tick ran (missed deadlines)"},
    },
    "required": ["tick", "start_s", "period_s", "jitter_s", "missed"],
    "additionalProperties": False,
}
