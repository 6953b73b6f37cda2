"""``replay --update``: a new reference recording from a replay.

The recording's frames are kept, except the controller's: each tick's frames
are replaced by what the current controller sent on the same inputs (at the
recorded frames' times; extra frames at the time of the last one). Everything
else of an MCAP trace is copied (metadata, MJCF, simulation truth, events,
other topics); the DBC attachments, git revision and parameters become the
current ones, and ``/controller/debug`` holds the replayed controller's
internals. The simulation truth is the recorded run's: replay is open loop.
"""
from __future__ import annotations

import math
from pathlib import Path

import can

from wheelleg import dbc
from wheelleg.hil.record.candump import CandumpWriter
from wheelleg.hil.analyze.replay import ReplayResult
from wheelleg.hil.record.frame import Frame
from wheelleg.hil import robots
from wheelleg.hil.record.run_metadata import git_revision
from wheelleg.hil.record.sources import ROLES

DEBUG_TOPIC = "/controller/debug"


def _replacements(result: ReplayResult) -> tuple[dict[int, list[Frame]], set[int]]:
    """Frame index -> frames written in its place; indices dropped."""
    if len(result.sent) != len(result.schedule.steps):
        raise ValueError("replay(..., keep_sent=True) is needed to write a reference")
    frames = result.source.frames
    put: dict[int, list[Frame]] = {}
    drop: set[int] = set()
    for step, sent in zip(result.schedule.steps, result.sent):
        for role in ROLES:
            slots, got = step.expected[role], sent.get(role, [])
            for j, idx in enumerate(slots):
                if j < len(got):
                    put[idx] = [_as_frame(frames[idx], got[j])]
                else:
                    drop.add(idx)
            if len(got) > len(slots):
                last = slots[-1]
                put.setdefault(last, []).extend(_as_frame(frames[last], m) for m in got[len(slots):])
    return put, drop


def _as_frame(at: Frame, msg: can.Message) -> Frame:
    return Frame.of(msg, at.channel, at.t_ns, at.bus)


def updated_frames(result: ReplayResult) -> list[Frame]:
    """The recording's frames with the controller's replaced by the replayed ones."""
    put, drop = _replacements(result)
    out = []
    for i, frame in enumerate(result.source.frames):
        if i in put:
            out.extend(put[i])
        elif i not in drop:
            out.append(frame)
    return out


def write_reference(result: ReplayResult, out: Path | str) -> Path:
    """Write the new reference (same format as the recording) to ``out``."""
    out = Path(out)
    frames = updated_frames(result)
    if result.source.kind == "mcap":
        _write_mcap(result, frames, out)
    else:
        with CandumpWriter(out, flush_interval_s=None) as log:
            for f in frames:
                log.write(f)
    return out


def _metadata(result: ReplayResult) -> dict:
    meta = {name: dict(record) for name, record in result.source.metadata.items()}
    run = meta.setdefault("run", {})
    run["reference_from"] = result.source.path.name
    run["reference_of_revision"] = run.get("git_revision", "unknown")
    run["git_revision"] = git_revision()
    run["controller_params"] = robots.get(result.source.robot).params_json()
    return meta


def _attachments(result: ReplayResult) -> list:
    files = [(p.name, p.read_bytes(), "text/x-dbc") for p in dbc.all_dbc_files()]
    names = {name for name, _, _ in files}
    for name, data in sorted(result.source.attachments.items()):
        if name not in names:
            files.append((name, data, "application/xml" if name.endswith(".xml") else "application/octet-stream"))
    return files


def _write_mcap(result: ReplayResult, frames: list[Frame], out: Path) -> None:
    from wheelleg.hil.record.trace import DECODED_PREFIX, CAN_PREFIX, EVENTS_TOPIC, SIM_STATE_TOPIC, TraceWriter

    reader = result.source.trace
    records = [(f.t_ns, 0, "frame", f) for f in frames]
    skip = (CAN_PREFIX, DECODED_PREFIX, DEBUG_TOPIC)
    for topic in reader.topics:
        if not topic.startswith(skip):
            records += [(t, 1, topic, payload) for t, payload in reader.topic(topic)]
    for step, debug in zip(result.schedule.steps, result.debug):
        if debug:
            end = max(result.source.frames[step.expected[role][-1]].t_ns for role in ROLES)
            records.append((end, 1, DEBUG_TOPIC, debug))
    records.sort(key=lambda r: (r[0], r[1]))
    channels = result.source.channels
    dbs = {channels[role]: result.source.dbs[role] for role in ROLES}
    robot = robots.get(result.source.robot)
    with TraceWriter(out, metadata=_metadata(result), attachments=_attachments(result), dbs=dbs,
                     flush_interval_s=None, sim_state_fields=robot.sim_state_fields) as trace:
        for t_ns, _, kind, item in records:
            if kind == "frame":
                trace.frame(item)
            elif kind == SIM_STATE_TOPIC:
                trace.sim_state(t_ns, {k: math.nan if v is None else v for k, v in item.items() if k != "t"})
            elif kind == EVENTS_TOPIC:
                trace.event(t_ns, item.pop("kind", "event"), **item)
            elif kind == DEBUG_TOPIC and robot.debug_schema is not None:  # as the rig records it
                trace.numbers(kind, t_ns, item, robot.debug_schema)
            else:
                trace.message(kind, t_ns, item, kind.strip("/").replace("/", "."))
