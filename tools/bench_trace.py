"""Benchmark (not a test): microseconds per recorded frame, trace and candump log; a trace's size by topic.

    python -m tools.bench_trace [--frames N]
    python -m tools.bench_trace --size TRACE.mcap     # e.g. out/balance.mcap of `wheelleg run balance`

The frame mix is one control period of the rig, repeated: on CAN1 SYNC, the
C620 current command, four C620 feedbacks, IMU and heartbeat; on CAN2 SYNC,
four CyberGear type-1 torque commands (torque in the id), four type-2
feedbacks and heartbeat. Payloads are encoded with the DBC beforehand, so
only the recording is timed. Timings on a shared 2-core machine are noisy:
take the best of a few repeats.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from wheelleg import dbc
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.record import schemas
from wheelleg.hil.record import trace as trace_module
from wheelleg.hil.record.candump import CandumpWriter
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.trace import TraceWriter

PERIOD_NS = 2_000_000  # one tick of the mix below, ns


def _encode(db, name: str, **values) -> tuple[int, bool, bytes]:
    message = db.get_message_by_name(name)
    full = {s.name: values.get(s.name, 0) for s in message.signals}
    return message.frame_id, message.is_extended_frame, message.encode(full)


def frame_mix() -> list[tuple[str, int, bool, bytes]]:
    """(channel, id, extended, data) of one control period."""
    db1, db2 = dbc.load_bus("can1"), dbc.load_bus("can2")
    frames = [("can1", *_encode(db1, "SYNC")), ("can1", *_encode(db1, "C620_Cmd_1_4", ESC1_Current=1.5)),
              ("can1", *_encode(db1, "IMU_Orientation")), ("can1", *_encode(db1, "IMU_Gyro")),
              ("can1", *_encode(db1, "Heartbeat"))]
    for i in range(1, 5):
        frames.append(("can1", *_encode(db1, f"C620_Feedback_{i}", RotorSpeed=1000, TorqueCurrent=0.5)))
    frames.append(("can2", *_encode(db2, "SYNC")))
    _, _, feedback = _encode(db2, "CG_Feedback", Pos=0.3, Vel=1.0, Torque=2.0, Temp=30)
    for motor in range(1, 5):
        frames.append(("can2", cg.motion_id(0.25 * motor, motor), True, bytes(8)))
        frames.append(("can2", cg.reply_id(cg.T_FEEDBACK, motor, 0xFD, mode=2), True, feedback))
    frames.append(("can2", *_encode(db2, "Heartbeat")))
    return frames


def time_trace(path: Path, n_frames: int, decode: bool) -> float:
    """Microseconds per frame through TraceWriter.on_frames, a tick at a time (including the final flush)."""
    mix = frame_mix()
    dbs = {"can1": dbc.load_bus("can1"), "can2": dbc.load_bus("can2")}
    writer = TraceWriter(path, metadata={"run": {"bench": "1"}}, dbs=dbs, decode=decode).start()
    ticks = n_frames // len(mix)
    batches = [[Frame(tick * PERIOD_NS + k * 100_000, channel, can_id, ext, data, len(data))
                for k, (channel, can_id, ext, data) in enumerate(mix)] for tick in range(ticks)]
    on_frames = writer.on_frames
    t0 = time.perf_counter()
    for batch in batches:
        on_frames(batch)
    writer.finish()
    return (time.perf_counter() - t0) / (ticks * len(mix)) * 1e6


def time_sim_state(path: Path, n_calls: int) -> float:
    """Microseconds per TraceWriter.sim_state call (once per control period in the rig)."""
    state = {key: 0.1 * i for i, key in enumerate(schemas.SIM_STATE_FIELDS) if key != "t"}
    writer = TraceWriter(path, metadata={"run": {"bench": "1"}}).start()
    t0 = time.perf_counter()
    for k in range(n_calls):
        writer.sim_state(k * PERIOD_NS, state)
    writer.finish()
    return (time.perf_counter() - t0) / n_calls * 1e6


def time_candump(path: Path, n_frames: int) -> float:
    mix = frame_mix()
    ticks = n_frames // len(mix)
    with CandumpWriter(path) as log:
        write = log.write
        frames = [Frame(tick * PERIOD_NS + k * 100_000, channel, can_id, ext, data, len(data))
                  for tick in range(ticks) for k, (channel, can_id, ext, data) in enumerate(mix)]
        t0 = time.perf_counter()
        for frame in frames:
            write(frame)
    return (time.perf_counter() - t0) / (ticks * len(mix)) * 1e6


def size_report(path: Path) -> str:
    """Where a trace's bytes go: per topic its messages, their records (uncompressed), the zstd of those
    records concatenated (level 1, as the chunks), and the message index (16 B a message); the total per
    simulated second."""
    import zstandard  # noqa: PLC0415
    from mcap.reader import make_reader  # noqa: PLC0415

    records: dict[str, list[bytes]] = {}
    t_min, t_max = None, 0
    with open(path, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            records.setdefault(channel.topic, []).append(message.data)
            t_min = message.log_time if t_min is None else min(t_min, message.log_time)
            t_max = max(t_max, message.log_time)
    span_s = max((t_max - (t_min or 0)) / 1e9, 1e-9)
    size = path.stat().st_size
    lines = [f"{path}: {size / 1e6:.2f} MB, {span_s:.2f} s of log time: {size / 1e6 / span_s:.3f} MB per s",
             f"  {'topic':34s} {'messages':>9s} {'records MB':>10s} {'zstd MB':>8s} {'index MB':>8s}"]
    groups: dict[str, list[bytes]] = {}
    for topic, recs in records.items():
        key = "/decoded/*" if topic.startswith("/decoded/") else topic
        groups.setdefault(key, []).extend(recs)
    compress = zstandard.ZstdCompressor(level=1).compress
    for topic, recs in sorted(groups.items()):
        raw = b"".join(recs)
        lines.append(f"  {topic:34s} {len(recs):9d} {len(raw) / 1e6:10.3f} {len(compress(raw)) / 1e6:8.3f} "
                     f"{16 * len(recs) / 1e6:8.3f}")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--size", type=Path, default=None, metavar="TRACE",
                        help="instead: where the bytes of TRACE go, by topic (messages, records, zstd, index)")
    args = parser.parse_args(argv)
    if args.size is not None:
        print(size_report(args.size))
        return 0
    json_lib = "orjson" if trace_module.orjson is not None else "json (stdlib)"
    print(f"{args.frames} frames per run, best of {args.repeats}; JSON encoder: {json_lib}")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for label, fn in [("trace, raw frames only (decode=False)", lambda: time_trace(out / "a.mcap", args.frames, False)),
                          ("trace, raw + decoded (decode=True)", lambda: time_trace(out / "b.mcap", args.frames, True)),
                          ("candump log", lambda: time_candump(out / "c.log", args.frames)),
                          ("sim_state (per call)", lambda: time_sim_state(out / "s.mcap", args.frames // 20))]:
            best = min(fn() for _ in range(args.repeats))
            print(f"  {label:40s} {best:6.2f} us/{'call' if 'call' in label else 'frame'}")
        size = (out / "b.mcap").stat().st_size
        print(f"  decoded trace size: {size / args.frames:.1f} bytes/frame (zstd)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
