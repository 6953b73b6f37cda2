"""What the robot's frame layout costs each bus at a control rate: ``python -m tools.layout_load TRACE``.

Reads a steady stretch of a rig trace (a balance run), measures each frame
kind's wire bits exactly (``wheelleg.hil.bus.busload.frame_bits``: the recorded payloads,
stuff bits included) and its rate, and scales the frames that go with the
control loop (commands, CyberGear replies, SYNC, heartbeat) to other control
rates. Frames a device sends on its own clock (C620 feedback at 1 kHz, IMU at
500 Hz, remote at 50 Hz) keep their rate.

    wheelleg run balance --duration 2 --out /tmp/bl --no-plot
    python -m tools.layout_load /tmp/bl/balance.mcap --rates 500 1000

``--buses N ...`` lays the measured frames out on N buses instead (a legged
robot's table: each leg's CyberGears, ids 1 + 3 leg + joint, on bus
leg * N // 4; the IMU and the remote on bus 0; SYNC and heartbeat on every
bus) and prints the busiest bus's load per bus count and control rate:

    wheelleg run quadruped/quad-balance-stand --duration 3 --out /tmp/ql --no-plot
    python -m tools.layout_load /tmp/ql/quad-balance-stand.mcap --control-hz 250 --from 2.5 \\
        --buses 1 2 4 --rates 250 500 1000
"""
from __future__ import annotations

import argparse
from collections import defaultdict

from wheelleg.dbc import cybergear as cg
from wheelleg.dbc import load_bus
from wheelleg.hil.bus.busload import DEFAULT_BITRATE, frame_bits
from wheelleg.hil.record.sources import Recording, open_recording

_DB1 = load_bus("can1")
_SYNC_KIND = f"0x{_DB1.get_message_by_name('SYNC').frame_id:03X}"
_LOOP_STD_IDS = {_DB1.get_message_by_name(n).frame_id for n in ("SYNC", "Heartbeat", "C620_Cmd_1_4")}


def frame_kind(arbitration_id: int, is_extended: bool) -> str:
    """A name for one kind of frame: the CyberGear type and motor, or the standard id."""
    if is_extended:
        motor = cg.reply_motor(arbitration_id) if cg.comm_type(arbitration_id) == cg.T_FEEDBACK \
            else cg.target(arbitration_id)
        return f"cybergear type {cg.comm_type(arbitration_id)} motor {motor}"
    return f"0x{arbitration_id:03X}"


def follows_the_loop(arbitration_id: int, is_extended: bool) -> bool:
    """Sent once per control tick (or in answer to one): scales with the control rate."""
    return is_extended or arbitration_id in _LOOP_STD_IDS


def measure(recording: Recording, t0_s: float, t1_s: float) -> dict:
    """bus -> kind -> (frames/s, mean wire bits, follows the loop) over [t0_s, t1_s)."""
    bits = defaultdict(lambda: defaultdict(list))
    loop = {}
    for frame in recording.frames:
        if not t0_s * 1e9 <= frame.t_ns < t1_s * 1e9 or frame.is_error:
            continue
        kind = frame_kind(frame.arbitration_id, frame.is_extended)
        bus = frame.bus or frame.channel
        bits[bus][kind].append(frame_bits(frame.arbitration_id, frame.is_extended, bytes(frame.data)))
        loop[kind] = follows_the_loop(frame.arbitration_id, frame.is_extended)
    span = t1_s - t0_s
    return {bus: {k: (len(v) / span, sum(v) / len(v), loop[k]) for k, v in kinds.items()}
            for bus, kinds in bits.items()}


def load_at(kinds: dict, measured_hz: float, control_hz: float, bitrate: int = DEFAULT_BITRATE) -> float:
    """Load fraction of one bus at ``control_hz`` from its kinds measured at ``measured_hz``."""
    total = 0.0
    for rate, mean_bits, loop in kinds.values():
        total += rate * (control_hz / measured_hz if loop else 1.0) * mean_bits
    return total / bitrate


LEGS, MOTORS_PER_LEG = 4, 3  # a quadruped's CyberGears: id = 1 + 3 leg + joint
_PER_BUS_KINDS = {f"0x{_DB1.get_message_by_name(n).frame_id:03X}" for n in ("SYNC", "Heartbeat")}


def kind_motor(kind: str) -> int | None:
    """The CyberGear id of a ``frame_kind`` ('cybergear type T motor M'), None for a standard frame."""
    return int(kind.rsplit(" ", 1)[1]) if kind.startswith("cybergear") else None


def spread(table: dict, n_buses: int) -> list[dict]:
    """``measure``'s kinds laid out on ``n_buses`` buses: per bus, kind -> (frames/s, mean bits, follows the loop).

    Each leg's motors go to bus leg * n_buses // LEGS; SYNC and heartbeat (one per bus per tick) to every
    bus, as measured on one; every other kind (IMU, remote) to bus 0.
    """
    buses = [{} for _ in range(n_buses)]
    for kinds in table.values():
        for kind, value in kinds.items():
            motor = kind_motor(kind)
            if kind in _PER_BUS_KINDS:
                for bus in buses:
                    bus[kind] = value
            elif motor is not None:
                buses[((motor - 1) // MOTORS_PER_LEG) * n_buses // LEGS][kind] = value
            else:
                buses[0][kind] = value
    return buses


def layout_table(table: dict, measured_hz: float, bus_counts, rates, bitrate: int = DEFAULT_BITRATE) -> list[str]:
    """Markdown rows: per bus count, the busiest bus's load (each bus's in brackets) at each control rate."""
    head = "| buses | " + " | ".join(f"{hz:g} Hz" for hz in rates) + " |"
    rows = [head, "|" + "---|" * (len(rates) + 1)]
    for n in bus_counts:
        cells = []
        for hz in rates:
            loads = [load_at(kinds, measured_hz, hz, bitrate) * 100 for kinds in spread(table, n)]
            each = " / ".join(f"{x:.0f}" for x in loads)
            cells.append(f"{max(loads):.1f} %" + (f" ({each})" if n > 1 else ""))
        rows.append(f"| {n} | " + " | ".join(cells) + " |")
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.layout_load", description=__doc__.splitlines()[0])
    parser.add_argument("trace", help="MCAP trace of a steady run (balance)")
    parser.add_argument("--from", dest="t0", type=float, default=0.5, help="start of the steady stretch (s)")
    parser.add_argument("--to", dest="t1", type=float, default=None, help="end (s; default: the trace's end - 0.1)")
    parser.add_argument("--control-hz", type=float, default=500.0, help="control rate the trace ran at")
    parser.add_argument("--rates", type=float, nargs="+", default=[500.0, 1000.0], help="control rates to show")
    parser.add_argument("--buses", type=int, nargs="+", default=None, metavar="N",
                        help="lay a legged robot's frames out on N buses (the busiest bus's load per N and rate)")
    args = parser.parse_args(argv)
    try:
        recording = open_recording(args.trace, strict=False)
        t_end = recording.trace.sim_state().get("t", []) if recording.trace is not None else []
    except Exception as exc:  # noqa: BLE001 - any unreadable file: say so, no traceback
        parser.error(f"cannot read {args.trace}: {exc}")
    if not len(t_end):
        parser.error(f"{args.trace}: no /sim/state (not a rig trace)")
    t1 = float(t_end[-1]) - 0.1 if args.t1 is None else args.t1
    table = measure(recording, args.t0, t1)
    if args.buses:
        print("\n".join(layout_table(table, args.control_hz, args.buses, args.rates)))
        return 0
    for bus in sorted(table):
        kinds = table[bus]
        print(f"{bus}:")
        for kind, (rate, mean_bits, loop) in sorted(kinds.items()):
            print(f"  {kind:<28} {rate:7.1f} /s  {mean_bits:6.1f} bits{'  (control loop)' if loop else ''}")
        robot = {k: v for k, v in kinds.items() if k != _SYNC_KIND}  # the rig's SYNC is not on the robot
        print("  with the rig's SYNC: " + ", ".join(
            f"{hz:g} Hz {load_at(kinds, args.control_hz, hz) * 100:.1f} %" for hz in args.rates))
        print("  robot only:          " + ", ".join(
            f"{hz:g} Hz {load_at(robot, args.control_hz, hz) * 100:.1f} %" for hz in args.rates))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
