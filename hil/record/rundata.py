"""Read a run's trace back into arrays for checks and plots (``RunData``)."""
from __future__ import annotations

from collections import defaultdict, namedtuple
from pathlib import Path

import numpy as np

from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import CAN1, load_file
from wheelleg.hil import robots
from wheelleg.hil.bus.busload import LOAD_TOPIC, max_frame_bits, wire_ns_batch
from wheelleg.hil.record.frame import Frame, FrameColumns
from wheelleg.hil.record.sources import TraceError, is_heartbeat, open_recording, sent_by_controller
from wheelleg.hil.record.trace import TraceReader
from wheelleg.hil.run.scenario import NoHeartbeat, RunData


LOAD_WINDOW_NS = 100_000_000  # the /bus/load windows
_Wire = namedtuple("_Wire", "arbitration_id is_extended data")  # what ``wire_ns_batch`` reads of a frame
_CG_MOTOR = 0xFF  # a CyberGear request id's motor id bits (7..0)
_MOTION = load_file("cybergear.dbc").get_message_by_name("CG_MotionCmd")
_KP, _KD = _MOTION.get_signal_by_name("Kp"), _MOTION.get_signal_by_name("Kd")  # big-endian u16, bytes 4-5, 6-7


def _commands(buses: list[FrameColumns]) -> tuple[dict, dict]:
    """What type-1 (MIT) frames commanded, per motor id (in the order each first commands): (t (n,) s,
    torque feed-forward (n,) N m) and (t (n,) s, Kp (n,) N m/rad, Kd (n,) N m s/rad)."""
    parts: dict[int, list[tuple]] = {}  # motor -> (t, tau, kp, kd) of each bus it is on
    for frames in buses:
        ids = frames.arbitration_id
        full = np.fromiter(map(len, frames.data), dtype=np.int64, count=len(frames.data)) == 8
        motion = np.flatnonzero(frames.is_extended & ~frames.is_error & full & (cg.comm_type(ids) == cg.T_MOTION))
        if not len(motion):
            continue
        targets = cg.target(ids[motion])
        words = np.frombuffer(b"".join([frames.data[i] for i in motion.tolist()]), dtype=">u2").reshape(-1, 4)
        _, first = np.unique(targets, return_index=True)
        for motor in targets[np.sort(first)].tolist():
            rows = targets == motor
            at = motion[rows]
            parts.setdefault(motor, []).append((frames.t_ns[at] / 1e9, cg.motion_torque(ids[at]),
                                                words[rows, 2] * _KP.scale + _KP.offset,
                                                words[rows, 3] * _KD.scale + _KD.offset))
    series = {motor: [np.concatenate(column) for column in zip(*bus_parts)] for motor, bus_parts in parts.items()}
    return ({k: (t, tau) for k, (t, tau, _, _) in series.items()},
            {k: (t, kp, kd) for k, (t, _, kp, kd) in series.items()})


def _motor_roles(robot: str) -> list[str]:
    """The buses that carry CyberGear motors on ``robot`` (its registry entry)."""
    return [bus.role for bus in robots.get(robot).buses if any(d.kind == "cybergear" for d in bus.devices)]


def _currents(reader: TraceReader, wheels_channel: str) -> dict:
    decoded = reader.decoded(wheels_channel, "C620_Cmd_1_4")
    if not decoded or "t" not in decoded:
        return {}
    return {i: (decoded["t"], decoded[f"ESC{i}_Current"]) for i in range(1, 5)
            if f"ESC{i}_Current" in decoded}


def load_run(path: Path | str) -> RunData:
    """Everything the checks need from a trace file (an MCAP trace of the rig)."""
    recording = open_recording(path, strict=False)
    reader = recording.trace
    if reader is None:
        raise TraceError(f"{path}: run data needs the rig's MCAP trace, not a candump log")
    channels = recording.channels
    can1 = channels.get(CAN1, "")
    torques, gains = _commands([reader.frame_columns(channels[role]) for role in _motor_roles(recording.robot)
                                if role in channels])
    return RunData(
        state=reader.sim_state(),
        heartbeat=reader.decoded(can1, "Heartbeat") or NoHeartbeat(),
        hip_torque=torques,
        joint_gains=gains,
        wheel_current=_currents(reader, can1),
        events=recording.events,
        meta=dict(recording.run, truncated=recording.truncated),
        bus_load=_bus_load(reader, {name: role for role, name in channels.items()}),
        program=dict(recording.metadata.get("program", {})),
        **(_program_frames(reader, channels, recording.dbs) if _judged_on_the_bus(recording) else {}),
    )


def _judged_on_the_bus(recording) -> bool:
    """Whether the checks read the program's command times: a program other than the in-process Python one."""
    program = recording.metadata.get("program", {})
    return program.get("judged_by") == "bus" or program.get("kind") in ("library", "command")


def _program_frames(reader: TraceReader, channels: dict, dbs: dict) -> dict:
    """``command_times`` and ``program_load`` of a run (``RunData``): what the bus shows of its program.

    ``command_times``: role -> (n,) s of the program's commands to its most commanded device on that bus (a
    CyberGear's requests of any type by motor id: motion commands when running, stops when
    disabled, the enable sequence; a standard frame by its id; heartbeats are not commands; the
    DBC's senders say whose a frame is): a frame or a few back to back each tick, its tick times
    when they cannot be seen otherwise. One device, not all of a tick's frames: on a busy bus a
    tick's frames queue behind others and the next tick's can follow close, so bursts do not
    mark ticks. ``program_load``: role -> the largest share of a 100 ms window its own frames
    (heartbeats aside) held the bus at 1 Mbit/s: a flood is the program's, whatever else loads the bus."""
    out, queued, load = {}, {}, {}
    for role, channel in channels.items():
        columns = reader.frame_columns(channel)
        ids = columns.arbitration_id.astype(np.int64)
        extended = columns.is_extended.astype(bool)
        dlc = np.fromiter(map(len, columns.data), dtype=np.int64, count=len(columns.data))
        # whose each frame is: worked out once per (id, extended, length, error)
        kinds = ids | (extended.astype(np.int64) << 32) | (dlc << 33) | (columns.is_error.astype(np.int64) << 40)
        unique, which = np.unique(kinds, return_inverse=True)
        theirs = np.array([_program_frame(int(k), channel, role, dbs) for k in unique.tolist()], dtype=bool)
        mine = np.flatnonzero(theirs[which]) if len(unique) else np.zeros(0, dtype=np.int64)
        t_ns = np.asarray(columns.t_ns, dtype=np.int64)
        if len(mine):
            wire = np.asarray(wire_ns_batch([_Wire(int(ids[i]), bool(extended[i]), columns.data[i]) for i in mine.tolist()],
                                            1_000_000), dtype=np.int64)
            _, held = np.unique(t_ns[mine] // LOAD_WINDOW_NS, return_inverse=True)
            load[role] = float(np.bincount(held, weights=wire).max()) / LOAD_WINDOW_NS
            # a device: a CyberGear by its motor id, a standard frame by its id; sorted (device, extended)
            device = (np.where(extended[mine], ids[mine] & _CG_MOTOR, ids[mine]) << 1) | extended[mine]
            devices, counts = np.unique(device, return_counts=True)
            picked = mine[device == devices[np.argmax(counts)]]
            bound = max_frame_bits(extended, dlc) * 1_000  # ns at 1 Mbit/s
            out[role] = t_ns[picked] / 1e9
            queued[role] = busy_since_ns(t_ns, bound)[picked] / 1e9
        else:
            out[role], queued[role], load[role] = np.zeros(0), np.zeros(0), 0.0
    return {"command_times": out, "command_queued": queued, "program_load": load}


def _program_frame(kind: int, channel: str, role: str, dbs: dict) -> bool:
    """Whether frames of ``kind`` (id | extended << 32 | length << 33 | error << 40) are the
    program's own (the DBC's senders say so), heartbeats aside."""
    ident, ext, length, err = kind & 0xFFFFFFFF, bool(kind >> 32 & 1), kind >> 33 & 0x7F, bool(kind >> 40 & 1)
    frame = Frame(0, channel, ident, ext, bytes(length), length, role, err)
    return not err and sent_by_controller(frame, dbs) and not is_heartbeat(frame)


BACK_TO_BACK_SLACK_NS = 5_000  # ns past the longer frame's wire time (3 bits of intermission at 1 Mbit/s, and rounding)


def busy_since_ns(t_ns, wire) -> np.ndarray:
    """(n,) ns: for each frame of a bus (times ``t_ns`` (n,) in order, ``wire`` (n,) ns each may
    hold the bus: its length, or ``max_frame_bits``' bound), when the stretch of back-to-back
    frames it ends began: the earliest its sender can have queued it, as every frame of the
    stretch may have held it back. A frame after idle bus time is its own start. Captures with
    timing noise (a real vcan) rarely look back to back, so there this is the frame's own time."""
    times = np.asarray(t_ns, dtype=np.int64)
    if times.size < 2:
        return times.copy()
    wire = np.asarray(wire, dtype=np.int64)
    back_to_back = np.diff(times) <= np.maximum(wire[1:], wire[:-1]) + BACK_TO_BACK_SLACK_NS
    first = np.where(np.concatenate(([False], back_to_back)), 0, np.arange(times.size))
    return times[np.maximum.accumulate(first)]


def _bus_load(reader: TraceReader, buses: dict) -> dict:
    """/bus/load per bus: "can1"/"can2" -> (window end t (n,) s, load (n,))."""
    series = defaultdict(lambda: ([], []))
    for t_ns, row in reader.topic(LOAD_TOPIC):
        t, load = series[buses.get(row.get("channel"), row.get("channel"))]
        t.append(t_ns / 1e9)
        load.append(float(row["load"]))
    return {k: (np.array(t), np.array(v)) for k, (t, v) in series.items()}
