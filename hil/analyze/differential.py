"""The differential check: two programs fed the same recorded inputs tick by tick, their commands compared.

The inputs and ticks are replay's (hil/analyze/replay.py: the frames the recorded
program received, each tick's SYNC in a rig trace, the log's tick boundaries in a
robot's log); each program runs on its own in-memory buses through the same driver,
so both see exactly the same frames at the same controller times. Each tick, the
commands each sent (every frame but the heartbeat, which a library's adapter makes)
are paired in send order per bus and decoded through the DBC (a CyberGear command's
torque lives in its id: ``cybergear_id.dbc``). A signal differs when |A - B| is
more than one step of its quantisation (its DBC scale: two programs that compute
the same value in different float arithmetic may round it to neighbouring steps).

Reported: the first tick and signal that differs (which message, which motor, the
two values), a differing frame count or message, and per signal the largest |A - B|
over the run as a percentage of its full scale (the DBC's minimum..maximum, else the
raw field's span).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import can

from wheelleg import dbc
from wheelleg.dbc import cybergear as cg
from wheelleg.hil.analyze.replay import build_schedule, driver_for, recorded_period
from wheelleg.hil.record.decode import FrameDecoder
from wheelleg.hil.record.sources import CONTROLLER_NODES, HEARTBEAT, ROLES, open_recording


def signal_scales(dbs: dict) -> dict[str, tuple[float, float, str]]:
    """Signal name -> (quantisation step, full scale, unit) over the messages the controller sends
    on ``dbs`` (role -> database) and the CyberGear id fields; an integer field (a flag, a mode, an
    index) has step 0: any difference counts."""
    out = {}
    for db in (*dbs.values(), dbc.load_file(cg.ID_DBC)):
        for message in db.messages:
            if not CONTROLLER_NODES.intersection(message.senders or ()):
                continue
            for s in message.signals:
                step = abs(float(s.scale)) if not float(s.scale).is_integer() else 0.0
                span = (float(s.maximum) - float(s.minimum)) if s.minimum is not None and s.maximum is not None \
                    else 0.0
                raw_span = abs(float(s.scale)) * (2 ** s.length - 1)
                out.setdefault(s.name, (step, span if span > 0 else raw_span, s.unit or ""))
    return out


@dataclass
class SignalDiff:
    """The largest |A - B| of one signal over the run; ``where``: its first tick beyond one step."""

    label: str  # 'can2 CG_MotionCmd motor 1 TorqueRef'
    max_abs: float = 0.0
    full_scale: float = 1.0
    unit: str = ""
    first_tick: int | None = None

    @property
    def percent(self) -> float:
        return 100.0 * self.max_abs / self.full_scale if self.full_scale else math.inf


@dataclass
class FirstDifference:
    tick: int
    time_s: float
    label: str  # the signal, or '<frames>' / '<message>' for a structural difference
    a: object
    b: object
    step: float = 0.0
    unit: str = ""

    def describe(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        text = f"first difference at tick {self.tick} (controller time {self.time_s:.6f} s): {self.label}: " \
               f"A {_show(self.a)}{unit}, B {_show(self.b)}{unit}"
        if isinstance(self.a, (int, float)) and isinstance(self.b, (int, float)):
            text += f" (|A - B| {abs(self.a - self.b):.6g} > one step {self.step:.6g})"
        return text


def _show(value) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


@dataclass
class DiffResult:
    mode: str
    ticks: int = 0
    first: FirstDifference | None = None
    signals: dict[str, SignalDiff] = field(default_factory=dict)
    differing_ticks: int = 0

    @property
    def equal(self) -> bool:
        return self.first is None


def differential(path, build_a, build_b, *, channels: dict | None = None, robot: str | None = None,
                 period_s: float | None = None) -> DiffResult:
    """Feed programs A and B (node factories: ``Program.node_factory``) the recording's inputs; see the
    module docstring. Raises ``TraceError`` when the recording cannot be replayed."""
    source = open_recording(path, channels, robot=robot)
    schedule = build_schedule(source)
    period = recorded_period(source, period_s)
    t0 = min(f.t_ns for f in source.frames)
    kind = driver_for(schedule)
    drivers = (kind(build_a, period, t0), kind(build_b, period, t0))
    result = DiffResult(schedule.mode)
    compare = _Comparer(FrameDecoder(source.dbs), signal_scales(source.dbs), result)
    try:
        for step in schedule.steps:
            (sent_a, now, _), (sent_b, _, _) = (d.step(step) for d in drivers)
            result.ticks += 1
            compare.tick(step.tick, now if not math.isnan(now) else step.tick * period, sent_a, sent_b)
    finally:
        for d in drivers:
            d.close()
    return result


class _Comparer:
    def __init__(self, decoder: FrameDecoder, scales: dict, result: DiffResult):
        self.decoder, self.scales, self.result = decoder, scales, result

    def tick(self, tick: int, now_s: float, sent_a: dict, sent_b: dict) -> None:
        found = None
        for role in ROLES:
            a, b = _commands(sent_a.get(role, [])), _commands(sent_b.get(role, []))
            if len(a) != len(b):
                found = found or FirstDifference(tick, now_s, f"{role} <frames>", f"{len(a)} commands",
                                                 f"{len(b)} commands")
            for fa, fb in zip(a, b):
                diff = self._frame(tick, now_s, role, fa, fb)  # every pair: it records each signal's max
                found = found or diff
        if found is not None:
            self.result.differing_ticks += 1
            if self.result.first is None:
                self.result.first = found

    def _frame(self, tick: int, now_s: float, role: str, fa: can.Message, fb: can.Message):
        """Record each signal's |A - B|; the first difference beyond a step in this frame pair, or None."""
        da = self.decoder.decode(role, fa.arbitration_id, fa.is_extended_id, bytes(fa.data[:fa.dlc]))
        db = self.decoder.decode(role, fb.arbitration_id, fb.is_extended_id, bytes(fb.data[:fb.dlc]))
        label_a, label_b = _label(role, fa, da), _label(role, fb, db)
        if da is None or db is None or label_a != label_b:
            if (fa.arbitration_id, bytes(fa.data)) == (fb.arbitration_id, bytes(fb.data)):
                return None
            return FirstDifference(tick, now_s, f"{role} <message>", label_a, label_b)
        first = None
        for name in dict.fromkeys([*da[1], *db[1]]):
            va, vb = da[1].get(name), db[1].get(name)
            if not isinstance(va, (int, float)) or not isinstance(vb, (int, float)):
                continue
            step, full, unit = self.scales.get(name, (0.0, 1.0, ""))
            key = f"{label_a} {name}"
            diff = self.result.signals.setdefault(key, SignalDiff(key, full_scale=full, unit=unit))
            gap = abs(float(va) - float(vb))
            diff.max_abs = max(diff.max_abs, gap)
            if gap > step * (1 + 1e-9) + 1e-12:
                if diff.first_tick is None:
                    diff.first_tick = tick
                first = first or FirstDifference(tick, now_s, key, float(va), float(vb), step, unit)
        return first


def _commands(frames: list[can.Message]) -> list[can.Message]:
    """A tick's frames but the heartbeat (the rig's, for a library: not the program's command)."""
    return [f for f in frames if f.is_extended_id or f.arbitration_id != HEARTBEAT.frame_id]


def _label(role: str, msg: can.Message, decoded) -> str:
    """'can2 CG_MotionCmd motor 1', 'can1 C620_Cmd_1_4', or the raw id when the DBC does not know it."""
    if decoded is None:
        ident = f"0x{msg.arbitration_id:08X}" if msg.is_extended_id else f"0x{msg.arbitration_id:03X}"
        return f"{role} {ident}"
    name = decoded[0].name
    return f"{role} {name} motor {cg.target(msg.arbitration_id)}" if msg.is_extended_id else f"{role} {name}"


def report(result: DiffResult, names: tuple[str, str]) -> str:
    """The command's text: verdict, first difference, per-signal max |A - B| as % of full scale."""
    what = f"{result.ticks} ticks, {result.mode} mode; A = {names[0]}, B = {names[1]}"
    lines = [f"{'EQUAL' if result.equal else 'DIFFERENT'} within one quantisation step ({what})"]
    if result.first is not None:
        lines += [f"  {result.first.describe()}",
                  f"  {result.differing_ticks} of {result.ticks} ticks differ"]
    shown = [d for d in result.signals.values() if d.max_abs > 0]
    lines.append("  per signal that differed, max |A - B| (% of full scale), first tick beyond one step:")
    for diff in sorted(shown, key=lambda d: (-d.percent, d.label)):
        tick = "-" if diff.first_tick is None else str(diff.first_tick)
        lines.append(f"    {diff.label:<40} {diff.max_abs:10.6g} {diff.unit:<9} {diff.percent:7.3f} %  {tick}")
    lines.append(f"  {len(result.signals) - len(shown)} other signals equal in every tick")
    return "\n".join(lines)
