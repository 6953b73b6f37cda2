"""Offline devices, device faults, frame loss, bus off, overload.

Each scenario balances on flat ground, injects one fault at ``FAULT_AT`` and
judges the controller's reaction from the trace: the time from the fault to
the last non-zero torque command against the device's offline threshold
(controller/detect.py RULES) plus one control period, silence on the motors
after that (no type-1 frame, zero ESC current), the heartbeat's warning
level, offline mask and mode, and a controller that answered every SYNC.
"""
from __future__ import annotations

import numpy as np

from wheelleg.controller import detect
from wheelleg.controller import params as P
from wheelleg.controller.modes import Mode
from wheelleg.hil.run import faults
from wheelleg.hil.run.scenario import Check, NoHeartbeat, NotJudged, RunData, Scenario, in_window
from wheelleg.hil.scenarios.basic import standing
from wheelleg.hil.scenarios.common import DEG, bus_command_timing, judged_on_the_bus, pitch_below, push, remote, stand

FAULT_AT = 1.0  # s: the robot balances by then
PERIOD = P.CONTROL_PERIOD
TORQUE_EPS_NM = 1e-3  # a zero torque command decodes to -0.18 mN m (16-bit field over +-12 N m)
CURRENT_EPS_A = 1e-3
_RULES = {r.name: (bit, r) for bit, r in enumerate(detect.RULES)}
JOINT_NAMES = tuple(r.name for r in detect.RULES[:4])


# -- reading the trace ---------------------------------------------------------------------
def fault_time(run: RunData, kind: str) -> float:
    """When the first ``kind`` fault event happened (s)."""
    hits = run.events_of(kind)
    if not hits:
        raise NotJudged(f"no {kind} event in the trace")
    return float(hits[0]["t"])


def reenable_time(run: RunData, after_s: float) -> float:
    """When the operator first pressed Reenable after ``after_s`` (inf: never)."""
    presses = [e["t"] for e in run.events_of("operator") if e.get("Reenable") == 1 and e["t"] > after_s]
    return float(min(presses)) if presses else float("inf")


def nonzero_command_times(run: RunData) -> np.ndarray:
    """Times (s) of every hip torque or wheel current command that is not zero, sorted, shape (n,)."""
    times = [t[np.abs(tau) > TORQUE_EPS_NM] for t, tau in run.hip_torque.values()]
    times += [t[np.abs(i) > CURRENT_EPS_A] for t, i in run.wheel_current.values()]
    return np.sort(np.concatenate(times)) if times else np.zeros(0)


def expected_report(devices) -> tuple[int, int, int]:
    """(offline mask, count, warning level) the heartbeat must show with ``devices`` offline."""
    mask = sum(1 << _RULES[d][0] for d in devices)
    return mask, len(devices), max(_RULES[d][1].warning_level for d in devices)


def reaction_bound(devices) -> float:
    """s: the first of ``devices`` to be declared offline, plus one control period."""
    return min(_RULES[d][1].offline_after_s for d in devices) + PERIOD


# -- checks --------------------------------------------------------------------------------
def torque_off_within(kind: str, bound_s: float, why: str) -> Check:
    """The last non-zero torque command comes at most ``bound_s`` after the fault."""

    def fn(run: RunData):
        t_f = fault_time(run, kind)
        until = reenable_time(run, t_f)
        times = nonzero_command_times(run)
        if not np.any(times < t_f):
            return False, "no torque command before the fault: the robot was not running"
        window = times[(times >= t_f) & (times < until)]
        last = float(window[-1]) if len(window) else float(times[times < t_f][-1])
        reaction = last - t_f
        return reaction <= bound_s, (f"last non-zero torque command {reaction * 1000:.2f} ms after the fault "
                                     f"(bound {bound_s * 1000:.0f} ms: {why})")

    return Check(f"torque off within {bound_s * 1000:.0f} ms of {kind}", fn)


def motors_stay_off(kind: str, bound_s: float) -> Check:
    """From fault + ``bound_s`` to the operator's re-enable: no type-1 frame, zero current, MotorsEnabled 0."""

    def fn(run: RunData):
        t0 = fault_time(run, kind) + bound_s
        t1 = reenable_time(run, t0)
        motion = sum(int(np.count_nonzero((t >= t0) & (t < t1))) for t, _ in run.hip_torque.values())
        current = max((float(np.max(np.abs(i[(t >= t0) & (t < t1)]), initial=0.0))
                       for t, i in run.wheel_current.values()), default=0.0)
        hb = run.heartbeat
        if isinstance(hb, NoHeartbeat):  # a program on its own clock: what it commands is all there is
            t = run.state["t"]
            ok = motion == 0 and current < CURRENT_EPS_A and bool(np.any((t >= t0) & (t < t1)))
            return ok, (f"{motion} torque commands, max wheel current {current:.3f} A over "
                        f"{t0:.3f}-{min(t1, float(t[-1])):.3f} s (no heartbeat: its MotorsEnabled not read)")
        sel = (hb["t"] >= t0) & (hb["t"] < t1)
        enabled = int(np.count_nonzero(hb["MotorsEnabled"][sel]))
        ok = motion == 0 and current < CURRENT_EPS_A and enabled == 0 and np.any(sel)
        return ok, (f"{motion} torque commands, max wheel current {current:.3f} A, {enabled} heartbeats with "
                    f"motors enabled over {t0:.3f}-{min(t1, float(hb['t'][-1])):.3f} s")

    return Check(f"motors off after {kind} until re-enabled", fn)


def heartbeat_reports(kind: str, devices, mode: Mode = Mode.DISABLED, until_kind: str | None = None,
                      fault_latched: bool = False) -> Check:
    """Once every device in ``devices`` is past its threshold: mask, count, level, mode and FaultLatched.

    Until the fault ends (``until_kind``'s first event after it) or the run ends.
    """
    mask, count, level = expected_report(devices)
    settle = max(_RULES[d][1].offline_after_s for d in devices) + PERIOD

    def fn(run: RunData):
        t_f = fault_time(run, kind)
        ends = [e["t"] for e in run.events_of(until_kind or "") if e["t"] > t_f]
        t1 = min(ends) if ends else np.inf
        hb = run.heartbeat
        sel = (hb["t"] >= t_f + settle) & (hb["t"] < t1)
        if not np.any(sel):
            return False, "no heartbeat in the window"
        bad = ((hb["OfflineMask"][sel] != mask) | (hb["OfflineCount"][sel] != count)
               | (hb["WarningLevel"][sel] != level) | (hb["Mode"][sel] != int(mode))
               | (hb["FaultLatched"][sel] != int(fault_latched)))
        n_bad = int(np.count_nonzero(bad))
        first = np.nonzero(sel)[0][0]
        return n_bad == 0, (f"{int(np.count_nonzero(sel))} heartbeats from {t_f + settle:.3f} s: {n_bad} differ "
                            f"from mask 0x{mask:02x}, count {count}, level {level}, mode {mode.name}, "
                            f"fault latched {int(fault_latched)} "
                            f"(first: mask 0x{int(hb['OfflineMask'][first]):02x}, level "
                            f"{int(hb['WarningLevel'][first])}, mode {Mode(int(hb['Mode'][first])).name})")

    what = "faulted" if fault_latched else "offline"
    return Check(f"heartbeat: {'+'.join(devices)} {what}, level {level}, {mode.name}", fn, needs_heartbeat=True)


def back_online_but_disabled(kind: str) -> Check:
    """After the fault ends: the offline mask clears, and the motors stay off until Reenable."""

    def fn(run: RunData):
        ends = [e["t"] for e in run.events_of("fault_end") if e.get("fault") == kind.removeprefix("fault_")]
        if not ends:
            raise NotJudged(f"no fault_end event of {kind} in the trace")
        t_end = min(ends)
        press = reenable_time(run, t_end)
        hb = run.heartbeat
        sel = (hb["t"] > t_end) & (hb["t"] < press)
        online = sel & (hb["OfflineMask"] == 0)
        if not np.any(online):
            return False, "the devices never came back online before the re-enable"
        enabled = int(np.count_nonzero(hb["MotorsEnabled"][sel]))
        back = float(hb["t"][online][0]) - t_end
        return enabled == 0, (f"online {back * 1000:.0f} ms after the fault ended; {enabled} heartbeats with "
                              f"motors enabled before the operator's re-enable")

    return Check("back online, still disabled until the operator re-enables", fn)


def reenabled_by_operator(within_s: float) -> Check:
    """The Reenable press turns the motors back on within ``within_s`` (the remote sends at 50 Hz)."""

    def fn(run: RunData):
        press = reenable_time(run, 0.0)
        hb = run.heartbeat
        on = hb["t"][(hb["t"] >= press) & (hb["MotorsEnabled"] == 1)]
        delay = float(on[0]) - press if len(on) else float("inf")
        return delay <= within_s, f"motors enabled {delay * 1000:.0f} ms after the Reenable press (by {within_s * 1000:.0f} ms)"

    return Check(f"re-enabled within {within_s * 1000:.0f} ms of the operator's command", fn)


def mismatch_time(run: RunData, kind: str, esc_id: int, tolerance_a: float, lasting_s: float) -> tuple[float, float]:
    """(held current A, start s of the first run of commands off it by > ``tolerance_a`` lasting ``lasting_s``)."""
    t_f = fault_time(run, kind)
    t, amps = run.wheel_current[esc_id]
    held = float(amps[t < t_f][-1])  # the last command the ESC took
    start = None
    for ti, off in zip(t[t >= t_f], np.abs(amps[t >= t_f] - held) > tolerance_a):
        start = (ti if start is None else start) if off else None
        if start is not None and ti - start >= lasting_s - 1e-6:
            return held, float(start)
    return held, float("inf")


def esc_hold_caught(kind: str, device: str, esc_id: int) -> Check:
    """Once the commands leave the held current: torque off within ESC_MISMATCH_S + 2 periods, then off,
    and the heartbeat shows the ESC faulted (mask bit, FaultLatched, DISABLED) while it holds."""
    bound = P.ESC_MISMATCH_S + 2 * PERIOD  # one period for the feedback to show it, one for the tick
    mask, _, level = expected_report([device])

    def fn(run: RunData):
        held, t_m = mismatch_time(run, kind, esc_id, P.ESC_CURRENT_TOLERANCE_A, P.ESC_MISMATCH_S)
        if not np.isfinite(t_m):
            return False, f"the commands never left the held {held:.2f} A for long: nothing to catch"
        times = nonzero_command_times(run)
        last = float(times[times >= t_m][-1]) if np.any(times >= t_m) else t_m
        hip_after = sum(int(np.count_nonzero(t > t_m + bound)) for t, _ in run.hip_torque.values())
        hb = run.heartbeat
        sel = hb["t"] >= t_m + bound
        shown = np.all((hb["OfflineMask"][sel].astype(int) & mask) == mask) and np.all(hb["FaultLatched"][sel] == 1) \
            and np.all(hb["WarningLevel"][sel] >= level) and np.all(hb["Mode"][sel] == int(Mode.DISABLED))
        ok = last - t_m <= bound and hip_after == 0 and bool(shown) and np.any(sel)
        return ok, (f"held {held:.2f} A; commands left it at {t_m:.3f} s; last non-zero torque command "
                    f"{(last - t_m) * 1000:.2f} ms later (bound {bound * 1000:.0f} ms); {hip_after} torque commands "
                    f"after; heartbeat faulted/DISABLED: {bool(shown)}")

    return Check(f"{device} not following its command is caught within {bound * 1000:.0f} ms", fn)


def controller_alive() -> Check:
    """Every SYNC answered: one heartbeat per tick, ticks consecutive, no deadline miss."""

    def fn(run: RunData):
        crashes = [e.get("error", "?") for e in run.events_of("controller_exception")]
        if judged_on_the_bus(run):  # another process in real time: its ticks show only on the bus
            ok, detail = bus_command_timing(run)
            return ok and not crashes, f"{detail}; exceptions: {crashes or 'none'}"
        ticks = run.heartbeat["Tick"]
        misses = len(run.events_of("deadline_miss"))
        expected = round(float(run.meta.get("duration_s", "nan")) / PERIOD)
        consecutive = bool(np.all(np.diff(ticks) == 1)) and len(ticks) and ticks[0] == 0
        ok = misses == 0 and not crashes and consecutive and len(ticks) == expected
        return ok, (f"{len(ticks)} heartbeats for {expected} ticks, consecutive: {consecutive}, {misses} deadline "
                    f"misses, exceptions: {crashes or 'none'}")

    return Check("controller answered every tick (no exception, no deadline miss)", fn)


def mode_never(mode: Mode, after_s: float) -> Check:
    def fn(run: RunData):
        hb = run.heartbeat
        n = int(np.count_nonzero((hb["t"] >= after_s) & (hb["Mode"] == int(mode))))
        worst = int(np.max(in_window(hb["t"], hb["OfflineCount"], after_s, np.inf, "the heartbeats")))
        return n == 0 and worst == 0, f"{n} heartbeats in {mode.name}, at most {worst} devices offline after {after_s:g} s"

    return Check(f"never {mode.name}, nothing offline after {after_s:g} s", fn)


def fault_affected_frames(kind: str, at_least: int) -> Check:
    """The fault really acted: its end event counts the frames it touched."""

    def fn(run: RunData):
        n = sum(int(e.get("frames_affected", 0)) for e in run.events_of("fault_end")
                if e.get("fault") == kind.removeprefix("fault_"))
        return n >= at_least, f"{kind} acted on {n} frames (at least {at_least})"

    return Check(f"{kind} acted on >= {at_least} frames", fn)


def bus_load_at_least(bus: str, load: float, t0: float, t1: float) -> Check:
    def fn(run: RunData):
        t, series = run.bus_load[bus]
        window = series[(t > t0 + 0.1) & (t <= t1)]  # windows that lie wholly inside
        if not len(window):
            raise NotJudged(f"no whole 100 ms load window in {t0:g}-{t1:g} s")
        worst = float(np.min(window))
        return worst >= load, f"{bus} load {worst * 100:.1f} % at least over {t0:g}-{t1:g} s (bound {load * 100:g} %)"

    return Check(f"{bus} load >= {load * 100:g} % during the overload", fn)


# -- scenarios -------------------------------------------------------------------------------
def offline(name: str, device: str, how: str = "silent", duration_s: float = 1.3) -> Scenario:
    """``device`` goes ``how`` (silent, or frozen: repeating its last frames) for good at FAULT_AT."""
    bound = reaction_bound([device])
    kind = f"fault_{how}"
    return Scenario(
        name, f"{device} goes {how} at {FAULT_AT:g} s: the motors stop within its threshold + one period",
        duration_s, standing(), timeline=(stand(), *getattr(faults, how)(device, FAULT_AT)),
        checks=(pitch_below(3 * DEG, 0.5, FAULT_AT),
                torque_off_within(kind, bound, f"{device} threshold + one period"),
                motors_stay_off(kind, bound), heartbeat_reports(kind, [device]), controller_alive()))


REMOTE_BACK = FAULT_AT + 0.3  # s
REENABLE_PRESS = REMOTE_BACK + 0.08  # s: after the remote is back and seen
FAULT_CLEAR_PRESS = FAULT_AT + 0.1  # s
LOSS_RATE = 0.05  # per frame, each bus, both ways
OVERLOAD_LOAD = 0.7  # babbling node's share of CAN2 on top of the 500 Hz traffic (~65 %)


def _remote_scenario() -> Scenario:
    bound = reaction_bound(["remote"])
    return Scenario(
        "offline-remote", "the remote drops out for 0.3 s: motors off, back online but disabled until Reenable",
        1.8, standing(),
        timeline=(stand(), *faults.silent("remote", FAULT_AT, REMOTE_BACK - FAULT_AT),
                  remote(REENABLE_PRESS, Reenable=1), remote(REENABLE_PRESS + 0.1, Reenable=0)),
        checks=(torque_off_within("fault_silent", bound, "remote threshold + one period"),
                motors_stay_off("fault_silent", bound),
                heartbeat_reports("fault_silent", ["remote"], until_kind="fault_end"),
                back_online_but_disabled("fault_silent"), reenabled_by_operator(0.05), controller_alive()))


def _motor_fault_scenario() -> Scenario:
    joint = "right_rear_hip"
    return Scenario(
        "motor-fault", f"{joint} latches over-temperature: motors off next tick; one Reenable press clears and enables",
        1.5, standing(),
        timeline=(stand(), *faults.cybergear_fault(joint, "FaultOverTemp", FAULT_AT),
                  remote(FAULT_CLEAR_PRESS, Reenable=1), remote(FAULT_CLEAR_PRESS + 0.1, Reenable=0)),
        checks=(torque_off_within("fault_cybergear", PERIOD, "the fault bit arrives in the next reply"),
                motors_stay_off("fault_cybergear", PERIOD),
                heartbeat_reports("fault_cybergear", [joint], until_kind="operator", fault_latched=True),
                reenabled_by_operator(0.05), controller_alive()))


def _esc_hold_scenario() -> Scenario:
    wheel = "left_wheel"
    return Scenario(
        "esc-hold", f"pushed (40 N, 0.1 s), the {wheel} C620 freezes its current mid-reaction (ignores commands)",
        1.4, standing(),
        timeline=(stand(), *push(FAULT_AT - 0.05, (40.0, 0.0, 0.0), 0.1), *faults.esc_hold(wheel, FAULT_AT)),
        checks=(esc_hold_caught("fault_esc_hold", wheel, 1), controller_alive()))


def _frame_loss_scenario() -> Scenario:
    loss = [a for bus in faults.BUSES
            for a in faults.frame_loss(bus, FAULT_AT - 0.5, 1.5, LOSS_RATE, direction=faults.BOTH)]
    return Scenario(
        "frame-loss", f"{LOSS_RATE:.0%} of the frames lost on both buses both ways for 1.5 s: keeps balancing",
        2.2, standing(), timeline=(stand(), *loss),
        checks=(pitch_below(2 * DEG, 0.5), mode_never(Mode.DISABLED, 0.3),
                fault_affected_frames("fault_frame_loss", 300), controller_alive()))


def _bus_off_scenario() -> Scenario:
    bound = reaction_bound(JOINT_NAMES)
    return Scenario(
        "bus-off", "CAN2 (joints) bus-off for 0.2 s: motors off within the joints' threshold, stay off after",
        1.5, standing(), timeline=(stand(), *faults.bus_off("can2", FAULT_AT, 0.2)),
        checks=(torque_off_within("fault_bus_off", bound, "joint threshold + one period"),
                motors_stay_off("fault_bus_off", bound),
                heartbeat_reports("fault_bus_off", JOINT_NAMES, until_kind="fault_end"),
                back_online_but_disabled("fault_bus_off"), controller_alive()))


def _overload_scenario() -> Scenario:
    bound = reaction_bound(JOINT_NAMES)
    return Scenario(
        "overload", f"a node babbles {OVERLOAD_LOAD:.0%} of CAN2 on top of the control traffic (~135 % demand); "
                    "with arbitration the joints' replies starve and the motors go off",
        1.5, standing(),
        timeline=(stand(), *faults.arbitration("can2", 0.0, None, OVERLOAD_MAX_WAIT_S),
                  *faults.babble("can2", FAULT_AT, 0.3, OVERLOAD_LOAD)),
        checks=(pitch_below(2 * DEG, 0.5, FAULT_AT),
                torque_off_within("fault_babble", bound, "joint threshold + one period"),
                motors_stay_off("fault_babble", bound),
                heartbeat_reports("fault_babble", JOINT_NAMES, until_kind="fault_end"),
                bus_load_at_least("can2", 0.95, FAULT_AT, FAULT_AT + 0.3), controller_alive()))


OVERLOAD_MAX_WAIT_S = 0.005  # s: a frame that cannot win the wire in 5 ms is aborted by its node

SCENARIOS: tuple = (
    offline("offline-wheel", "left_wheel"),
    offline("offline-joint", "left_front_hip"),
    offline("offline-imu", "imu"),
    offline("frozen-imu", "imu", how="frozen"),
    _remote_scenario(),
    _motor_fault_scenario(),
    _esc_hold_scenario(),
    _frame_loss_scenario(),
    _bus_off_scenario(),
    _overload_scenario(),
)
