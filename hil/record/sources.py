"""One view of a recorded run, from any file: the rig's MCAP trace, a candump log,
or any other log python-can's ``can.LogReader`` reads (.asc, .blf, .trc, .csv, ...).

``open_recording(path)`` gives a ``Recording``: every frame in order with its bus
role (``can1`` = wheels/IMU/remote, ``can2`` = CyberGear joints), plus what the
file says about the run (MCAP metadata, attachments, events; candump comments
and DROPCOUNT notices). Replay and inspect both read through it.

Bus roles (worked out here only): an MCAP trace of the rig names its channels in the ``run``
metadata; a candump log does not, so the role of each interface is inferred
from what it carries (the wheel-legged robot: CyberGear extended ids -> can2; C620, IMU or remote ids
-> can1; another robot: the CyberGear motor ids and the standard ids of the devices
its registered buses carry), or given by the caller (``channels={"can1": "can0", "can2": "can1"}``).

Which robot: an MCAP trace names it in the ``run`` metadata (``robot``); a log
is of the default robot unless the caller says (``open_recording(..., robot=...)``).
Its frames are read with that robot's bus databases (``Recording.dbs``).

Which frames are the controller's: the DBC says it. A frame is the
controller's when its DBC message lists a controller node among its senders
(``HOST`` in cybergear.dbc and c620.dbc, ``CONTROLLER`` in rig.dbc); CyberGear
frames are looked up at their canonical id (``wheelleg.dbc.cybergear.canonical_id``)
and a frame a motor sent (``cg.from_motor``: a reply to any host) is never the host's.
"""
from __future__ import annotations

import heapq
import zlib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Iterator

from wheelleg import dbc
from wheelleg.controller.constants import CG_HOST_ID
from wheelleg.hil import robots
from wheelleg.dbc import CAN1, CAN2
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.record.candump import CandumpReader, DropNotice, LogFormatError
from wheelleg.hil.record.frame import Frame

ROLES = dbc.BUSES
CONTROLLER_NODES = frozenset({"HOST", "CONTROLLER"})  # DBC node names of the controller
DBS = {role: dbc.load_bus(role) for role in ROLES}  # the default robot's
HEARTBEAT = DBS[CAN1].get_message_by_name("Heartbeat")
SYNC = DBS[CAN1].get_message_by_name("SYNC")
MCAP_MAGIC = b"\x89MCAP"


def checked_copy(trace: Path, out: Path, copy):
    """``copy(trace, out)`` (``wheelleg export``, ``recover``) once the copy may be made: (its result,
    None), or (None, why not) when ``trace`` is no MCAP file, ``out`` would overwrite it, or either
    cannot be read or written (``TraceError``, ``OSError``)."""
    try:
        refusal = _copy_refusal(trace, out)
        return (None, refusal) if refusal else (copy(trace, out), None)
    except TraceError as exc:
        return None, str(exc)
    except OSError as exc:
        return None, f"{exc.filename or trace}: {exc.strerror or exc}"


def _copy_refusal(trace: Path, out: Path) -> str | None:
    """Why a copy of ``trace`` to ``out`` must not be made: not an MCAP file, or ``out`` would
    overwrite it; None when it may. OSError if unreadable."""
    with open(trace, "rb") as f:
        if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            return f"{trace}: not an MCAP trace"
    if Path(out).resolve() == Path(trace).resolve():
        return f"{out}: the copy would overwrite the trace; give another -o"
    return None


class TraceError(Exception):
    """The file cannot be read or replayed; the message says why."""


@dataclass
class Recording:
    """A recorded run: frames in order plus what the file says about it.

    ``frames``: file order (candump); per bus in file order, merged by time
    (MCAP), each with its role in ``bus``. An MCAP trace's frames are read
    when first asked for; ``trace`` is its reader (sim state, decoded
    signals, any topic), None for a candump log.
    """

    path: Path
    kind: str  # "mcap" | "candump" | "python-can" (another format can.LogReader reads)
    channels: dict[str, str] = field(default_factory=dict)  # role -> interface name
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: dict[str, bytes] = field(default_factory=dict)
    events: list[dict] = field(default_factory=list)  # /scenario/events, each with "t" (s)
    drops: list[DropNotice] = field(default_factory=list)
    comments: int = 0
    truncated: bool = False
    trace: object = None  # wheelleg.hil.record.trace.TraceReader of an MCAP trace
    keep_unknown: bool = False  # frames of interfaces without a role: kept (role '') or ignored
    robot: str = robots.DEFAULT  # the registered robot it is a recording of
    raw_frames: list[Frame] | None = field(default=None, repr=False)  # a log's frames before roles
    _frames: list[Frame] | None = field(default=None, init=False, repr=False)
    _ignored: dict[str, int] = field(default_factory=dict, init=False, repr=False)

    @property
    def run(self) -> dict[str, str]:
        return self.metadata.get("run", {})

    @property
    def dbs(self) -> dict:
        """Role -> the cantools database of that bus of the recording's robot."""
        return robot_dbs(self.robot)

    @property
    def frames(self) -> list[Frame]:
        if self._frames is None:
            self._frames, self._ignored = _assign_roles(self._unassigned(), self.channels, self.keep_unknown)
        return self._frames

    @property
    def ignored_channels(self) -> dict[str, int]:
        """Interface -> frames left out because the interface has no role."""
        _ = self.frames
        return self._ignored

    def bus_frames(self, role: str) -> Iterator[Frame]:
        """The frames of one bus, in order (an MCAP trace reads only that channel)."""
        if self.trace is not None and self._frames is None:
            return self.trace.frames(self.channels[role], role) if role in self.channels else iter(())
        return (f for f in self.frames if f.bus == role)

    def _unassigned(self) -> list[Frame]:
        if self.raw_frames is None:  # MCAP: read now, with the roles already known
            role_of = {name: role for role, name in self.channels.items()}
            self.raw_frames = list(heapq.merge(*(self.trace.frames(name, role_of.get(name, ""))
                                                 for name in self.trace.channels()), key=lambda f: f.t_ns))
        return self.raw_frames

    @property
    def duration_s(self) -> float:
        if not self.frames:
            return 0.0
        return (max(f.t_ns for f in self.frames) - min(f.t_ns for f in self.frames)) / 1e9


def robot_dbs(robot: str) -> dict:
    """Role -> the cantools database of that bus of ``robot`` (the default robot's: ``DBS``)."""
    return DBS if robot == robots.DEFAULT else {role: dbc.load_files(files)
                                                for role, files in robots.bus_files(robot).items()}


# -- which frames are the controller's ------------------------------------------------------
def dbc_message(role: str, arbitration_id: int, is_extended: bool, dbs: dict | None = None):
    """The cantools message of a frame on bus ``role`` (CyberGear at its canonical id), or None;
    ``dbs``: role -> database (default: the default robot's, ``DBS``)."""
    db = (DBS if dbs is None else dbs).get(role)
    if db is None:
        return None
    frame_id = cg.canonical_id(arbitration_id) if is_extended else arbitration_id
    try:
        # cantools reads an id <= 0x7FF as standard unless told: type 0's canonical id is 0
        message = db.get_message_by_frame_id(frame_id, force_extended_id=is_extended)
    except KeyError:
        return None
    return message if message.is_extended_frame == is_extended else None


def sent_by_controller(frame: Frame, dbs: dict | None = None) -> bool:
    """True when the DBC (``dbs``, as ``dbc_message``) names a controller node as the sender of this frame."""
    if frame.is_error or frame.is_fd:
        return False
    message = dbc_message(frame.bus, frame.arbitration_id, frame.is_extended, dbs)
    if message is None or not CONTROLLER_NODES.intersection(message.senders or ()):
        return False
    return not (frame.is_extended and cg.from_motor(frame.arbitration_id, CG_HOST_ID))


def is_heartbeat(frame: Frame) -> bool:
    return (not frame.is_extended and not frame.is_error and frame.arbitration_id == HEARTBEAT.frame_id
            and len(frame.data) == HEARTBEAT.length)


def is_sync(frame: Frame) -> bool:
    return (not frame.is_extended and not frame.is_error and frame.arbitration_id == SYNC.frame_id
            and len(frame.data) == SYNC.length)


def heartbeat_tick(frame: Frame) -> int:
    return int(HEARTBEAT.decode(frame.data, decode_choices=False)["Tick"])


def sync_tick(frame: Frame) -> int:
    return int(SYNC.decode(frame.data, decode_choices=False)["Tick"])


# -- bus roles -------------------------------------------------------------------------------
def _role_votes(frames) -> dict[str, dict[str, int]]:
    """Interface -> {role: frames that only make sense on that role}."""
    can1_ids = {m.frame_id for m in dbc.load_file("c620.dbc").messages}
    can1_ids |= {m.frame_id for m in dbc.load_file("rig.dbc").messages} - {SYNC.frame_id, HEARTBEAT.frame_id}
    votes: dict[str, dict[str, int]] = {}
    for f in frames:
        v = votes.setdefault(f.channel, {CAN1: 0, CAN2: 0})
        if f.is_error or f.is_fd:
            continue
        if f.is_extended and dbc_message(CAN2, f.arbitration_id, True) is not None:
            v[CAN2] += 1
        elif not f.is_extended and f.arbitration_id in can1_ids:
            v[CAN1] += 1
    return votes


def _device_votes(frames, robot: robots.Robot) -> dict[str, dict[str, int]]:
    """Interface -> {role: frames of a device that ``robot``'s registry puts on that role}: CyberGear
    frames by motor id (to or from it), standard frames by the ids only that role's database knows."""
    dbs = robot_dbs(robot.name)
    motors = {d.can_id: bus.role for bus in robot.buses for d in bus.devices if d.kind == "cybergear"}
    own = {role: {m.frame_id for m in db.messages if not m.is_extended_frame} for role, db in dbs.items()}
    lockstep = {SYNC.frame_id, HEARTBEAT.frame_id}
    only = {role: ids - lockstep - set().union(*(v for r, v in own.items() if r != role)) for role, ids in own.items()}
    votes: dict[str, dict[str, int]] = {}
    for f in frames:
        v = votes.setdefault(f.channel, {role: 0 for role in ROLES})
        if f.is_error or f.is_fd:
            continue
        if f.is_extended:
            motor = cg.reply_motor(f.arbitration_id) if cg.is_reply(f.arbitration_id, CG_HOST_ID) \
                else cg.target(f.arbitration_id)
            role = motors.get(motor)
        else:
            role = next((r for r, ids in only.items() if f.arbitration_id in ids), None)
        if role is not None:
            v[role] += 1
    return votes


def infer_channels(frames, robot: str = robots.DEFAULT) -> dict[str, str]:
    """Role -> interface, from the frames each interface carries; {} entries left out if unsure."""
    votes = _role_votes(frames) if robot == robots.DEFAULT else _device_votes(frames, robots.get(robot))
    out = {}
    for role in ROLES:
        ranked = sorted(votes, key=lambda ch: votes[ch][role], reverse=True)
        if ranked and votes[ranked[0]][role] > 0:
            out[role] = ranked[0]
    if out.get(CAN1) is not None and out.get(CAN1) == out.get(CAN2):
        raise TraceError(f"interface {out[CAN1]!r} carries both CyberGear (CAN2) and C620/IMU (CAN1) "
                         "frames; the rig has them on two buses: pass the channels explicitly")
    return out


def parse_channels(text: str | None) -> dict[str, str] | None:
    """'can0,can1' -> {'can1': 'can0', 'can2': 'can1'} (CAN1 = wheels first, CAN2 = joints)."""
    if not text:
        return None
    names = [n.strip() for n in text.split(",")]
    if len(names) != 2 or not all(names) or names[0] == names[1]:
        raise TraceError(f"channels {text!r}: need two different names, CAN1 (wheels),CAN2 (joints)")
    return {CAN1: names[0], CAN2: names[1]}


def _assign_roles(frames: list[Frame], channels: dict[str, str], keep_unknown: bool):
    """Frames with their role set; frames of other interfaces kept (role '') or counted as ignored."""
    role_of = {name: role for role, name in channels.items()}
    out, ignored = [], {}
    for f in frames:
        role = role_of.get(f.channel)
        if role is None:
            if keep_unknown:
                out.append(f)
            else:
                ignored[f.channel] = ignored.get(f.channel, 0) + 1
            continue
        out.append(f if f.bus == role else replace(f, bus=role))
    return out, ignored


def _resolve_channels(recording: Recording, given: dict | None, strict: bool) -> dict:
    if given:
        return dict(given)
    recorded = recording.run
    if recorded and all(recorded.get(r) for r in ROLES):
        return {r: recorded[r] for r in ROLES}
    frames = recording._unassigned()
    inferred = infer_channels(frames, recording.robot)
    present = sorted({f.channel for f in frames})
    unknown = [ch for ch in present if ch not in inferred.values()]
    if strict and (len(inferred) < 2 or unknown):
        guess = ", ".join(f"{r}={n}" for r, n in inferred.items()) or "nothing"
        raise TraceError(f"cannot tell the buses apart: interfaces {present}, recognised {guess}"
                         + (f", unknown {unknown}" if unknown else "")
                         + "; pass --channels CAN1,CAN2 (wheels first, joints second)")
    return inferred


# -- loading ---------------------------------------------------------------------------------
def open_recording(path, channels: dict | None = None, *, strict: bool = True,
                   robot: str | None = None) -> Recording:
    """Read an MCAP trace or a candump log (plain or gzip-compressed).

    ``strict`` (replay): both bus roles must be known, frames of other
    interfaces are dropped (counted in ``ignored_channels``). ``strict=False``
    (inspect, run data): roles as far as they can be told, every frame kept.
    ``robot``: whose recording it is (default: the trace's ``run`` record says,
    else the default robot); a trace of another robot is refused.

    Raises ``TraceError`` with the reason when the file cannot be read.
    """
    path = Path(path)
    if not path.is_file():
        raise TraceError(f"{path}: no such file")
    with open(path, "rb") as f:
        head = f.read(len(MCAP_MAGIC))
    if head == MCAP_MAGIC:
        recording = _open_mcap(path)
    elif python_can_format(path):
        recording = _open_python_can_log(path)
    else:
        recording = _open_candump(path)
    recording.keep_unknown = not strict
    recording.robot = _robot_of(recording, robot)
    recording.channels = _resolve_channels(recording, channels, strict)
    recorded = {r: recording.run.get(r) for r in ROLES if recording.run.get(r)}
    if recording.trace is not None and not (recording.trace.decodes and recorded == recording.channels):
        # decode on reading with this rig's databases: the trace has no DBC of its own, or other channels
        dbs = recording.dbs
        recording.trace.decode_with({recording.channels[r]: dbs[r] for r in ROLES if r in recording.channels})
    return recording


def _robot_of(recording: Recording, given: str | None) -> str:
    """The robot of ``recording``: the trace's record, the caller's, else the default; TraceError if they differ
    or the registry does not know it."""
    recorded = recording.run.get("robot") or None
    if given is not None and recorded is not None and given != recorded:
        raise TraceError(f"{recording.path}: a recording of the {recorded} robot, not of the {given} robot")
    name = given or recorded or robots.DEFAULT
    try:
        robots.check_known(name)
    except KeyError as exc:  # not installed, or its plug-in is broken
        raise TraceError(f"{recording.path}: a recording of robot {name!r}, which this rig cannot load: "
                         f"{str(exc).strip(chr(39))}") from None
    return name


def _open_mcap(path: Path) -> Recording:
    from wheelleg.hil.record.trace import TraceReader  # noqa: PLC0415 (mcap only when needed)

    try:
        reader = TraceReader(path)
    except Exception as exc:  # a file that is not MCAP past its magic
        raise TraceError(f"{path}: not a readable MCAP trace: {exc}") from exc
    return Recording(path, "mcap", metadata=reader.metadata, attachments=dict(reader.attachments),
                     events=reader.events(), truncated=reader.truncated, trace=reader)


def python_can_format(path: Path) -> str | None:
    """The suffix (".asc", ".blf", ...) when python-can's ``LogReader`` reads ``path`` and the rig's
    own readers do not (the rig reads candump ``.log`` and MCAP itself); None otherwise."""
    import can.io.player  # noqa: PLC0415

    suffixes = [s.lower() for s in path.suffixes]
    if suffixes and suffixes[-1] == ".gz":
        suffixes.pop()
    suffix = suffixes[-1] if suffixes else ""
    return suffix if suffix in can.io.player.MESSAGE_READERS and suffix not in (".log", ".mcap") else None


def _open_python_can_log(path: Path) -> Recording:
    """A log in a format python-can reads; channels named as python-can gives them ("1", "can0", ...)."""
    import can  # noqa: PLC0415

    try:
        with can.LogReader(path) as reader:
            frames = [Frame.of(msg, "can" if msg.channel is None else str(msg.channel), round(msg.timestamp * 1e9))
                      for msg in reader]
    except Exception as exc:  # noqa: BLE001 - any reader's complaint, in one line
        raise TraceError(f"{path}: python-can cannot read it as {python_can_format(path)}: {exc}") from exc
    if not frames:
        raise TraceError(f"{path}: no CAN frames")
    return Recording(path, "python-can", raw_frames=frames)


def _open_candump(path: Path) -> Recording:
    reader = CandumpReader(path, strict=True)
    try:
        frames = list(reader)
    except LogFormatError as exc:
        raise TraceError(f"{exc.path}:{exc.line_no}: not a candump -L line ({exc.reason}): "
                         f"{exc.line[:80]!r}") from exc
    except UnicodeDecodeError as exc:
        raise TraceError(f"{path}: neither an MCAP trace nor a text candump log ({exc})") from exc
    except (EOFError, OSError, zlib.error) as exc:  # gzip.BadGzipFile is an OSError
        raise TraceError(f"{path}: a damaged gzip-compressed log ({exc})") from exc
    if not frames and not reader.drops:
        raise TraceError(f"{path}: no CAN frames (is it a `candump -L` log or an MCAP trace?)")
    return Recording(path, "candump", drops=list(reader.drops), comments=reader.comments,
                     truncated=reader.cut_off, raw_frames=frames)
