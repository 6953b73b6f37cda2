"""What a recording holds: ``summarize(path)`` for ``wheelleg inspect``.

Per interface: frames and rate per identifier (CyberGear frames grouped by
communication type and motor, since type-1 ids carry the torque), bus load
(``wheelleg.hil.bus.busload.frame_bits`` on the wire at ``bitrate``: mean over the
recording, peak over ``window_s`` windows), decoded signal ranges (min/max),
faults (CyberGear fault bits, the heartbeat's mode, warning level and offline
devices, scenario events of kind ``fault*``) and deadline misses (the rig's
``deadline_miss`` events, SYNC ticks without heartbeat, heartbeat ticks the
controller skipped). Works on the rig's MCAP traces and on candump logs.
"""
from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from wheelleg.controller.constants import CG_HOST_ID
from wheelleg.hil import robots
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.bus.busload import DEFAULT_BITRATE, frame_bits
from wheelleg.hil.record.decode import FrameDecoder
from wheelleg.hil.record.frame import Frame
from wheelleg.hil.record.sources import (CAN1, HEARTBEAT, Recording, is_heartbeat, is_sync,
                              open_recording, sync_tick)

KIND_NAMES = {"mcap": "MCAP trace", "candump": "candump log", "python-can": "log read by python-can"}
_FAULT_PREFIXES = ("Fault", "Warn")


@dataclass
class IdStats:
    channel: str
    ident: str  # '0x201', or the canonical id of a CyberGear type
    message: str  # DBC name (+ motor for CyberGear), '?' if unknown
    frames: int
    rate_hz: float  # (n - 1) / span; NaN for a single frame
    first_s: float
    last_s: float


@dataclass
class SignalRange:
    channel: str
    message: str
    signal: str
    minimum: float
    maximum: float
    count: int


@dataclass
class Finding:
    """A fault, warning or deadline miss at ``t_s`` (recording time)."""

    t_s: float
    kind: str  # 'cybergear', 'heartbeat', 'event', 'deadline'
    text: str


@dataclass
class TraceSummary:
    path: str
    kind: str
    channels: dict  # role -> interface
    start_s: float
    duration_s: float
    frames: int
    ids: list[IdStats] = field(default_factory=list)
    bus_load: dict = field(default_factory=dict)  # interface -> (mean, peak) fractions
    signals: list[SignalRange] = field(default_factory=list)
    faults: list[Finding] = field(default_factory=list)
    deadline_misses: list[Finding] = field(default_factory=list)
    events: dict = field(default_factory=dict)  # kind -> count
    notes: list[str] = field(default_factory=list)
    run: dict = field(default_factory=dict)
    program: dict = field(default_factory=dict)  # the trace's ``program`` record (hil/program), {} in older traces
    load_series: dict = field(default_factory=dict)  # interface -> (t (n,) s, load (n,))
    heartbeat: dict = field(default_factory=dict)  # 't', 'Mode', 'WarningLevel' -> (n,) arrays
    commands: dict = field(default_factory=dict)  # label -> (t (n,), value (n,)) torques/currents

    def rate(self, channel: str, message: str) -> float:
        """Rate (Hz) of one row, by interface and message label."""
        rows = [r for r in self.ids if r.channel == channel and r.message == message]
        if not rows:
            raise KeyError(f"no frames of {message!r} on {channel!r}")
        return rows[0].rate_hz


def _id_key(frame: Frame, plan) -> tuple[str, str, bool]:
    """(id label, message label, is a CyberGear reply): CyberGear per type and motor, others per id."""
    if frame.is_extended and plan is not None:
        ident = f"0x{cg.canonical_id(frame.arbitration_id):08X}"
        if cg.from_motor(frame.arbitration_id, CG_HOST_ID):  # the motor id sits in bits 15..8
            return ident, f"{plan.name} from motor {cg.reply_motor(frame.arbitration_id)}", True
        return ident, f"{plan.name} to motor {cg.target(frame.arbitration_id)}", False
    ident = f"0x{frame.arbitration_id:08X}" if frame.is_extended else f"0x{frame.arbitration_id:03X}"
    if frame.is_error:
        return ident, "error frame", False
    return ident, plan.name if plan is not None else "?", False


class _Pass:
    """One pass over the frames, collecting every figure."""

    def __init__(self, source: Recording, bitrate: int, window_s: float):
        self.source, self.bitrate, self.window_ns = source, bitrate, max(int(window_s * 1e9), 1)
        self.t0 = min((f.t_ns for f in source.frames), default=0)
        dbs = source.dbs  # the recording's robot's
        self.decoder = FrameDecoder({name: dbs[role] for role, name in source.channels.items()})
        self.counts: dict = {}
        self.bits: dict = defaultdict(lambda: defaultdict(int))  # channel -> window -> bits
        self.ranges: dict = {}
        self.fault_state: dict = {}
        self.faults: list[Finding] = []
        self.hb_channel = source.channels.get(CAN1)
        self.hb_rows: list = []
        self.hb_ticks: list[tuple[int, int]] = []
        self.sync_ticks: dict[int, int] = {}
        self.commands: dict = defaultdict(lambda: ([], []))

    def run(self) -> None:
        for f in self.source.frames:
            hit = None if f.is_error else self.decoder.decode(f.channel, f.arbitration_id, f.is_extended, f.data)
            plan, values = hit if hit is not None else (None, None)
            ident, label, reply = _id_key(f, plan)
            row = self.counts.get((f.channel, label))
            if row is None:
                row = self.counts[(f.channel, label)] = [ident, 0, f.t_ns, f.t_ns]
            row[1] += 1
            row[3] = f.t_ns
            if not f.is_error:
                self.bits[f.channel][(f.t_ns - self.t0) // self.window_ns] += frame_bits(
                    f.arbitration_id, f.is_extended, f.data, f.is_remote)
            if values is not None:
                self._values(f, plan.name, label, values, reply)
            self._clock(f)

    def _values(self, f: Frame, name: str, label: str, values: dict, reply: bool) -> None:
        for signal, value in values.items():
            if not isinstance(value, (int, float)) or not math.isfinite(value):
                continue
            key = (f.channel, name, signal)
            r = self.ranges.get(key)
            if r is None:
                self.ranges[key] = [value, value, 1]
            else:
                r[0], r[1], r[2] = min(r[0], value), max(r[1], value), r[2] + 1
        if reply:
            self._cybergear_faults(f, label, values)
        if f.is_extended and cg.comm_type(f.arbitration_id) == cg.T_MOTION and "TorqueRef" in values:
            self._command(f, f"{label} torque (N m)", values["TorqueRef"])
        elif name.startswith("C620_Cmd"):
            for signal, value in values.items():
                if value:
                    self._command(f, f"{signal} (A)", value)

    def _command(self, f: Frame, label: str, value: float) -> None:
        t, v = self.commands[label]
        t.append((f.t_ns - self.t0) / 1e9)
        v.append(value)

    def _cybergear_faults(self, f: Frame, label: str, values: dict) -> None:
        for signal, value in values.items():
            if not signal.startswith(_FAULT_PREFIXES):
                continue
            key = (f.channel, label, signal)
            was = self.fault_state.get(key, 0)
            if bool(value) != bool(was):
                state = "set" if value else "cleared"
                self.faults.append(Finding((f.t_ns - self.t0) / 1e9, "cybergear",
                                           f"{f.channel} {label}: {signal} {state}"))
            self.fault_state[key] = value

    def _clock(self, f: Frame) -> None:
        """Heartbeats and SYNCs of one interface (CAN1's, else the first with a heartbeat)."""
        if self.hb_channel is None and is_heartbeat(f):
            self.hb_channel = f.channel
        if f.channel != self.hb_channel:
            return
        if is_heartbeat(f):
            values = HEARTBEAT.decode(f.data, decode_choices=False)
            self.hb_rows.append(((f.t_ns - self.t0) / 1e9, values))
            self.hb_ticks.append((values["Tick"], f.t_ns))
        elif is_sync(f):
            self.sync_ticks.setdefault(sync_tick(f), f.t_ns)


def _heartbeat_findings(rows: list, robot: robots.Robot) -> list[Finding]:
    """A finding each time the heartbeat's mode, warning level, offline devices or latch change,
    named with ``robot``'s modes and offline bits."""
    out, last = [], None
    for t, v in rows:
        state = (v["Mode"], v["WarningLevel"], v["OfflineMask"], v["FaultLatched"])
        if state != last:
            offline = [name for bit, name in enumerate(robot.offline_bits) if v["OfflineMask"] >> bit & 1]
            mode = robot.mode_names.get(int(v["Mode"]), str(v["Mode"]))
            out.append(Finding(t, "heartbeat", f"mode {mode}, warning level {v['WarningLevel']}, offline "
                                               f"{', '.join(offline) or 'none'}"
                                               + (", fault latched" if v["FaultLatched"] else "")))
            last = state
    return out


def _deadline_findings(p: _Pass, source: Recording, period_s: float) -> list[Finding]:
    out = [Finding(e["t"] - p.t0 / 1e9, "deadline", f"deadline miss (tick {e.get('tick', '?')})")
           for e in source.events if e.get("kind") == "deadline_miss"]
    answered = {tick for tick, _ in p.hb_ticks}
    if p.sync_ticks:  # lockstep: every SYNC must get its heartbeat
        if not out:
            last = max(answered, default=-1)
            out += [Finding((t - p.t0) / 1e9, "deadline", f"SYNC({tick}) without heartbeat")
                    for tick, t in sorted(p.sync_ticks.items()) if tick not in answered and tick <= last]
        return out
    for (a, ta), (b, tb) in zip(p.hb_ticks, p.hb_ticks[1:]):  # free-run: late or skipped ticks
        late = (tb - ta) / 1e9 > 1.5 * period_s
        if b > a + 1 or late:
            out.append(Finding((tb - p.t0) / 1e9, "deadline",
                               f"tick {b} came {(tb - ta) / 1e6:.3f} ms after tick {a}"
                               + (f" ({b - a - 1} skipped)" if b > a + 1 else "")))
    return out


def summarize(path_or_source, *, bitrate: int = DEFAULT_BITRATE, window_s: float = 0.1,
              channels: dict | None = None, period_s: float = 0.002, robot: str | None = None) -> TraceSummary:
    """Read a trace or log and compute everything ``wheelleg inspect`` prints; ``robot`` as ``open_recording``."""
    source = path_or_source if isinstance(path_or_source, Recording) else \
        open_recording(path_or_source, channels, strict=False, robot=robot)
    p = _Pass(source, bitrate, window_s)
    p.run()
    duration = source.duration_s
    summary = TraceSummary(str(source.path), source.kind, dict(source.channels), p.t0 / 1e9, duration,
                           len(source.frames), run=dict(source.run),
                           program=dict(source.metadata.get("program", {})))
    for (channel, label), (ident, n, first, last) in sorted(p.counts.items(), key=lambda kv: (kv[0][0], kv[1][0], kv[0][1])):
        span = (last - first) / 1e9
        rate = (n - 1) / span if n > 1 and span > 0 else math.nan
        summary.ids.append(IdStats(channel, ident, label, n, rate, (first - p.t0) / 1e9, (last - p.t0) / 1e9))
    _loads(summary, p, bitrate, duration)
    summary.signals = [SignalRange(ch, m, s, lo, hi, n) for (ch, m, s), (lo, hi, n) in sorted(p.ranges.items())]
    events = [e for e in source.events if str(e.get("kind", "")).startswith("fault")]
    summary.faults = sorted(p.faults + _heartbeat_findings(p.hb_rows, robots.get(source.robot))
                            + [Finding(e["t"] - p.t0 / 1e9, "event", _event_text(e)) for e in events],
                            key=lambda x: x.t_s)
    summary.deadline_misses = _deadline_findings(p, source, period_s)
    for e in source.events:
        summary.events[e.get("kind", "?")] = summary.events.get(e.get("kind", "?"), 0) + 1
    if p.hb_rows:
        summary.heartbeat = {"t": np.array([t for t, _ in p.hb_rows]),
                             **{k: np.array([v[k] for _, v in p.hb_rows], dtype=float)
                                for k in ("Mode", "WarningLevel", "OfflineCount")}}
    summary.commands = {k: (np.array(t), np.array(v)) for k, (t, v) in sorted(p.commands.items())}
    summary.notes = _notes(source)
    return summary


def _loads(summary: TraceSummary, p: _Pass, bitrate: int, duration: float) -> None:
    window_s = p.window_ns / 1e9
    for channel, bins in sorted(p.bits.items()):
        total = sum(bins.values())
        mean = total / bitrate / duration if duration > 0 else math.nan
        full = [b for k, b in bins.items() if (k + 1) * window_s <= duration]  # whole windows only
        peak = max(full) / bitrate / window_s if full else mean
        summary.bus_load[channel] = (mean, peak)
        keys = np.arange(max(1, int(duration / window_s)))  # whole windows only
        summary.load_series[channel] = (keys * window_s, np.array([bins.get(k, 0) for k in keys]) / bitrate / window_s)


def _event_text(event: dict) -> str:
    fields = ", ".join(f"{k}={v}" for k, v in event.items() if k not in ("t", "kind"))
    return f"event {event.get('kind')}" + (f" ({fields})" if fields else "")


def _notes(source: Recording) -> list[str]:
    notes = []
    if source.drops:
        notes.append(f"{sum(d.dropped for d in source.drops)} frame(s) lost in {len(source.drops)} "
                     f"DROPCOUNT notice(s), first at line {source.drops[0].line_no}")
    if source.comments:
        notes.append(f"{source.comments} comment line(s)")
    if source.truncated:
        notes.append("the trace was not closed (writer killed): it ends at its last complete "
                     + ("line" if source.kind == "candump" else
                        f"chunk; `wheelleg recover {source.path}` writes an indexed copy that mcap's indexed "
                        "readers and Foxglove open"))
    unknown = sorted({f.channel for f in source.frames} - set(source.channels.values()))
    if unknown:
        notes.append(f"interfaces of unknown role (not decoded): {', '.join(unknown)}")
    return notes


# -- text and plot -----------------------------------------------------------------------------
def format_summary(s: TraceSummary, *, signals: bool = True, max_findings: int = 30) -> str:
    """The report ``wheelleg inspect`` prints."""
    run = s.run
    head = f"{s.path} ({KIND_NAMES.get(s.kind, s.kind)})"
    if run:
        head += (f": scenario {run.get('scenario', '?')}, seed {run.get('seed', '?')}, "
                 f"revision {run.get('git_revision', '?')[:12]}")
    roles = ", ".join(f"{role} = {name}" for role, name in sorted(s.channels.items())) or "bus roles unknown"
    lines = [head, f"duration {s.duration_s:.6f} s, {s.frames} frames; {roles}"]
    if s.program:
        from wheelleg.hil.program import describe  # noqa: PLC0415 (ctypes, only for a trace that names one)

        lines.append(f"program: {describe(s.program)}")
    lines += [f"note: {n}" for n in s.notes]
    lines.append("bus load (mean, peak over 100 ms windows):")
    lines += [f"  {ch:<10} {mean * 100:6.2f} %  peak {peak * 100:6.2f} %" for ch, (mean, peak) in s.bus_load.items()]
    lines.append("frames per id:")
    lines.append(f"  {'interface':<10} {'id':<11} {'message':<34} {'frames':>8} {'rate Hz':>9}")
    for r in s.ids:
        rate = "-" if math.isnan(r.rate_hz) else f"{r.rate_hz:.1f}"
        lines.append(f"  {r.channel:<10} {r.ident:<11} {r.message:<34} {r.frames:>8} {rate:>9}")
    if signals:
        lines.append("signal ranges:")
        lines += [f"  {r.channel:<10} {r.message + '.' + r.signal:<44} {r.minimum:>12.6g} .. {r.maximum:.6g}"
                  for r in s.signals]
    lines += _findings("faults and warnings", s.faults, max_findings)
    lines += _findings("deadline misses", s.deadline_misses, max_findings)
    if s.events:
        lines.append("events: " + ", ".join(f"{k} x{n}" for k, n in sorted(s.events.items())))
    return "\n".join(lines)


def _findings(title: str, findings: list[Finding], limit: int) -> list[str]:
    if not findings:
        return [f"{title}: none"]
    out = [f"{title}: {len(findings)}"]
    out += [f"  t={f.t_s:10.6f} s  {f.text}" for f in findings[:limit]]
    if len(findings) > limit:
        out.append(f"  ... {len(findings) - limit} more")
    return out


def plot_summary(s: TraceSummary, path: Path | str) -> Path:
    """Bus load, heartbeat mode/warning level and commands over time, faults marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for channel, (t, load) in s.load_series.items():
        axes[0].step(t, load * 100, where="post", label=channel)
    axes[0].set_ylabel("bus load (%)")
    if s.heartbeat:
        axes[1].step(s.heartbeat["t"], s.heartbeat["Mode"], where="post", label="mode")
        axes[1].step(s.heartbeat["t"], s.heartbeat["WarningLevel"], where="post", label="warning level")
    axes[1].set_ylabel("heartbeat")
    for label, (t, v) in s.commands.items():
        axes[2].plot(t, v, lw=0.7, label=label)
    axes[2].set_ylabel("commands (N m, A)")
    axes[2].set_xlabel("time since the first frame (s)")
    for f in s.faults + s.deadline_misses:
        for ax in axes:
            ax.axvline(f.t_s, color="red" if f.kind != "heartbeat" else "grey", lw=0.5, alpha=0.5)
    for ax in axes:
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right", fontsize=7)
    fig.suptitle(Path(s.path).name)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return Path(path)
