"""The CyberGear 29-bit identifier codec.

A CyberGear identifier is ``type << 24 | data16 << 8 | target`` (docs/protocols.md,
the 29-bit identifier); what ``data16`` holds depends on the type: the host id, a torque
feed-forward (type 1), mode and fault bits (type 2 and other replies) or a new
id (type 7). ``cybergear_id.dbc`` (``ID_DBC``) describes those fields with
pseudo messages (``CG_Id_*``: the identifier read as a little-endian u32);
this module reads their bit positions and scales once and does the
arithmetic, because a field that lives in the id cannot be decoded by
cantools from the payload.

Payloads sit in ``cybergear.dbc`` at a canonical id: the type alone.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

from wheelleg.dbc import load_file
from wheelleg.dbc.codec import truncate

TYPE_SHIFT = 24
ID_DBC = "cybergear_id.dbc"  # the id's fields, and the payloads a type alone does not select
DEVICE_ID_TARGET = 0xFE  # replies to type 0/7/22 go to this address
DEFAULT_MASTER = 0x00  # CAN_MASTER's factory value: where a motor answers unless told otherwise
FAULT_NAMES = ("FaultUnderVoltage", "FaultOverCurrent", "FaultOverTemp",
               "FaultMagEncoder", "FaultHallEncoder", "FaultNotCalibrated")

# communication types (docs/protocols.md)
T_DEVICE_ID, T_MOTION, T_FEEDBACK, T_ENABLE, T_STOP = 0, 1, 2, 3, 4
T_CALIBRATE, T_SET_ZERO, T_SET_ID, T_PARAM_READ, T_PARAM_WRITE = 5, 6, 7, 17, 18
T_PARAM_TABLE, T_BRAKE, T_FAULT_WARN, T_SET_BAUD = 19, 20, 21, 22
T_CONFIG_WRITE, T_CONFIG_READ = 8, 9  # the stored table 0x2000-0x302F, one entry
MAX_MOTOR_ID = 127  # parameter CAN_ID 0x200A: a motor's address is 0..127


@dataclass(frozen=True)
class _Field:
    shift: int
    mask: int

    def get(self, word: int) -> int:
        return (word >> self.shift) & self.mask

    def put(self, value: int) -> int:
        return (int(value) & self.mask) << self.shift


def _fields(message_name: str) -> dict[str, _Field]:
    msg = load_file(ID_DBC).get_message_by_name(message_name)
    return {s.name: _Field(s.start, (1 << s.length) - 1) for s in msg.signals}


_REQ = _fields("CG_Id_Request")
_MOT = _fields("CG_Id_Motion")
_REP = _fields("CG_Id_Reply")
_SET = _fields("CG_Id_SetId")
_TAB = _fields("CG_Id_ParamTable")
_TORQUE_SIGNAL = load_file(ID_DBC).get_message_by_name("CG_Id_Motion").get_signal_by_name("TorqueRef")
_FAULT_FIELDS = [(name, _REP[name]) for name in FAULT_NAMES]
# the fields the rig reads on every frame, as plain shift and mask (no dict or method call a frame)
_TYPE_SHIFT, _TYPE_MASK = _REQ["Type"].shift, _REQ["Type"].mask
_TARGET_SHIFT, _TARGET_MASK = _REQ["Target"].shift, _REQ["Target"].mask
_HOST_SHIFT, _HOST_MASK = _REQ["Host"].shift, _REQ["Host"].mask
_TORQUE_SHIFT, _TORQUE_MASK = _MOT["TorqueRef"].shift, _MOT["TorqueRef"].mask
_MOTION_TARGET_SHIFT, _MOTION_TARGET_MASK = _MOT["Target"].shift, _MOT["Target"].mask
_MOTION_TYPE = _MOT["Type"].put(T_MOTION)
# (lowest N m, highest N m, full raw) of the torque field: truncate's first three arguments
_TORQUE_LO, _TORQUE_HI, _TORQUE_FULL = _TORQUE_SIGNAL.minimum, _TORQUE_SIGNAL.maximum, (1 << _TORQUE_SIGNAL.length) - 1


def comm_type(can_id: int) -> int:
    """Communication type (bits 28..24)."""
    return (can_id >> _TYPE_SHIFT) & _TYPE_MASK


def canonical_id(can_id: int) -> int:
    """The id under which the payload layout sits in cybergear.dbc."""
    return _REQ["Type"].put(comm_type(can_id))


def target(can_id: int) -> int:
    """Bits 7..0: the receiver's address."""
    return (can_id >> _TARGET_SHIFT) & _TARGET_MASK


# --- host -> motor -----------------------------------------------------------
def request_id(ctype: int, host: int, motor: int) -> int:
    """Id of a host->motor request of type 0, 3, 4, 6, 17, 18, 21 or 22."""
    return _REQ["Type"].put(ctype) | _REQ["Host"].put(host) | _REQ["Target"].put(motor)


def request_host(can_id: int) -> int:
    """Host id (bits 15..8) of a request."""
    return (can_id >> _HOST_SHIFT) & _HOST_MASK


def motion_id(torque_nm: float, motor: int) -> int:
    """Id of a type-1 motion command carrying ``torque_nm`` (truncating encoder)."""
    raw = truncate(_TORQUE_LO, _TORQUE_HI, _TORQUE_FULL, torque_nm)  # truncating_raw of the torque signal
    # the target field's put (_Field.put) written out: four frames a control tick
    return (_MOTION_TYPE | ((raw & _TORQUE_MASK) << _TORQUE_SHIFT)
            | ((int(motor) & _MOTION_TARGET_MASK) << _MOTION_TARGET_SHIFT))


def motion_torque(can_id: int) -> float:
    """Feed-forward torque (N m) of a type-1 id."""
    raw = (can_id >> _TORQUE_SHIFT) & _TORQUE_MASK
    return raw * _TORQUE_SIGNAL.scale + _TORQUE_SIGNAL.offset


def set_id_id(new_id: int, host: int, motor: int) -> int:
    """Id of a type-7 change-id request."""
    return (_SET["Type"].put(T_SET_ID) | _SET["NewId"].put(new_id)
            | _SET["Host"].put(host) | _SET["Target"].put(motor))


def set_id_new_id(can_id: int) -> int:
    return _SET["NewId"].get(can_id)


# --- motor -> host -----------------------------------------------------------
@dataclass(frozen=True)
class ReplyId:
    """Fields of a motor->host identifier."""

    ctype: int
    motor_id: int
    host: int
    mode: int = 0  # 0 reset, 1 cali, 2 run, 3 brake
    faults: frozenset = frozenset()  # names from FAULT_NAMES


def reply_id(ctype: int, motor: int, host: int, mode: int = 0, faults=()) -> int:
    """Id of a motor->host frame: type 2 carries mode and faults."""
    word = _REP["Type"].put(ctype) | _REP["MotorId"].put(motor) | _REP["Host"].put(host)
    if ctype == T_FEEDBACK:
        word |= _REP["Mode"].put(mode)
        for name, field in _FAULT_FIELDS:
            if name in faults:
                word |= field.put(1)
    return word


def table_id(fragment: int, motor: int, host: int) -> int:
    """Id of a type-19 parameter-table answer: the fragment number in bits 23..16."""
    return (_TAB["Type"].put(T_PARAM_TABLE) | _TAB["Fragment"].put(fragment)
            | _TAB["MotorId"].put(motor) | _TAB["Host"].put(host))


def table_fragment(can_id: int) -> int:
    """Fragment number (bits 23..16) of a type-19 answer: 4 a number, 0 a string's start, 6..8 its parts."""
    return _TAB["Fragment"].get(can_id)


def is_reply(can_id: int, host_id: int) -> bool:
    """True for a motor->host frame, False for a request (host->motor).

    A reply's last byte addresses the host (``host_id``, or 0xFE for the
    device-id answers to types 0, 7 and 22); a request's addresses a motor
    (0..127). Types 0, 17 and 21 go both ways with the same type, so only
    this byte tells them apart.
    """
    return target(can_id) in (host_id, DEVICE_ID_TARGET)


def sent_by_host(can_id: int, host_id: int) -> bool:
    """True when bits 15..8 of a request may name a host rather than a motor.

    A motor's frames carry its own id (0..127) there; a host's carry the host
    id. So an id above 127 (0xFD, 0xFE: no motor can have it) is always a
    host, and one in 0..127 is a host only when it is ``host_id`` (the
    motor's CAN_MASTER): the rule that keeps a motor from answering another
    motor's reply.
    """
    sender = request_host(can_id)
    return sender == host_id or sender > MAX_MOTOR_ID


def from_motor(can_id: int, host_id: int) -> bool:
    """True for a motor->host frame to any host, False for a host->motor request.

    ``is_reply`` knows only ``host_id`` and 0xFE; a reply to the demo's and the
    firmware's default master 0x00 ends in 0x00 too, which also reads as a
    request to motor 0. Bits 15..8 settle it: a request's name a host
    (``sent_by_host``), a reply's the answering motor. A type-1 command is
    never a motor's (its bits 15..8 hold torque, not a sender).
    """
    if comm_type(can_id) == T_MOTION:
        return False
    if is_reply(can_id, host_id):
        return True
    return target(can_id) == DEFAULT_MASTER and not sent_by_host(can_id, host_id)


def reply_motor(can_id: int) -> int:
    """The sending motor's id in a motor->host identifier (bits 15..8)."""
    return _REP["MotorId"].get(can_id)


@lru_cache(maxsize=4096)  # a bus carries a few dozen reply ids; ReplyId is frozen, so one object serves all
def parse_reply_id(can_id: int) -> ReplyId:
    ctype = _REP["Type"].get(can_id)
    faults = frozenset(name for name, field in _FAULT_FIELDS if field.get(can_id))
    return ReplyId(ctype, _REP["MotorId"].get(can_id), _REP["Host"].get(can_id),
                   _REP["Mode"].get(can_id), faults if ctype == T_FEEDBACK else frozenset())
