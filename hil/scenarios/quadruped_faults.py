"""The quadruped's E-stop and offline scenarios: passive, soft-damped, in time.

Passive (the wiring contract's fault reaction, the MIT Cheetah's) is judged from the trace:
the heartbeat's Mode is PASSIVE, and every type-1 (MIT) command the controller
sends from then on has Kp = 0, no torque feed-forward and a damping Kd > 0 (the
joints soft-damped, not limp), until the operator asks for the motors again.
Time limits: an E-stop reaches the bus with the remote's next frame, so passive
within one remote period plus one control period; a silent motor is offline
after 20 ms without feedback, so passive within that plus one control period.
"""
from __future__ import annotations

import numpy as np

from wheelleg.controller.quadruped.modes import Mode
from wheelleg.emulators.quadruped import description as D
from wheelleg.hil.run import faults
from wheelleg.hil.run.scenario import Check, RunData, Scenario
from wheelleg.hil.scenarios.common import TORQUE_OFF_NM, first_mode, remote
from wheelleg.hil.scenarios.quadruped import (PERIOD_S, REMOTE_PERIOD_S, STAND_S, quad_scenario, stand_request,
                                              standing, upright_at_end)

OFFLINE_S = 0.020  # s without feedback after which a motor is offline (the contract: 5 periods)
ESTOP_S = 0.06  # s the switch stays on E-stop
DEVICES = (*(m.name for m in D.JOINT_MOTORS), "imu", "remote")


def _mode_before(run: RunData, t_s: float) -> int:
    before = run.heartbeat["Mode"][run.heartbeat["t"] < t_s]
    return int(before[-1]) if len(before) else -1


def passive_commands(run: RunData, t0: float, t1: float) -> tuple[int, float, float, float]:
    """Type-1 commands in [t0, t1): (count, max Kp N m/rad, max |torque| N m, min Kd N m s/rad)."""
    count, kp_max, tau_max, kd_min = 0, 0.0, 0.0, np.inf
    for motor, (t, kp, kd) in run.joint_gains.items():
        inside = (t >= t0) & (t < t1)
        tau = run.hip_torque[motor][1][inside]
        if inside.any():
            count += int(inside.sum())
            kp_max, tau_max = max(kp_max, float(kp[inside].max())), max(tau_max, float(np.abs(tau).max()))
            kd_min = min(kd_min, float(kd[inside].min()))
    return count, kp_max, tau_max, kd_min


def _passive_note(run: RunData, t_passive: float, t_end: float) -> tuple[bool, str]:
    n, kp, tau, kd = passive_commands(run, t_passive, t_end)
    ok = n > 0 and kp == 0.0 and tau < TORQUE_OFF_NM and kd > 0.0
    return ok, f"then {n} commands, Kp <= {kp:.2f}, |tau| <= {tau:.3f} N m, Kd >= {kd:.2f}"


def estops_make_passive(expected: tuple[Mode, ...]) -> Check:
    """Each E-stop (an operator event with EStop = 1): the mode before it as expected, PASSIVE in the heartbeat
    within one remote period + one control period, soft-damped commands until the next request for a mode."""
    limit = REMOTE_PERIOD_S + PERIOD_S

    def fn(run: RunData):
        ops = run.events_of("operator")
        stops = [e["t"] for e in ops if e.get("EStop") == 1]
        if len(stops) != len(expected):
            return False, f"{len(stops)} E-stops in the timeline, expected {len(expected)}"
        ok, notes = True, []
        for t_stop, mode in zip(stops, expected):
            was = _mode_before(run, t_stop)
            t_passive = first_mode(run, int(Mode.PASSIVE), t_stop)
            later = [e["t"] for e in ops if e["t"] > t_stop and e.get("Mode", 0) != 0]
            if t_passive is None:
                ok = False
                notes.append(f"{mode.name}: never PASSIVE")
                continue
            damped, note = _passive_note(run, t_passive, later[0] if later else np.inf)
            good = was == int(mode) and t_passive - t_stop <= limit + 1e-9 and damped
            ok = ok and good
            notes.append(f"{Mode(was).name if was >= 0 else '?'}: {(t_passive - t_stop) * 1000:.0f} ms, {note}")
        return ok, "; ".join(notes)

    return Check(f"E-stop: passive within {limit * 1000:.0f} ms from every mode, soft-damped", fn)


def estop_scenario() -> Scenario:
    """E-stop flicked in STAND_UP, BALANCE_STAND, LOCOMOTION and RECOVERY_STAND; after each the operator
    puts the switch to passive (re-arming) and asks for the next mode."""
    timeline = [stand_request(0.1)]
    plan = ((1.0, Mode.STAND_UP, None), (5.0, Mode.BALANCE_STAND, None),
            (9.5, Mode.LOCOMOTION, (8.5, dict(Mode=int(Mode.LOCOMOTION), VelX=0.2))),
            (11.0, Mode.RECOVERY_STAND, (10.4, dict(Mode=int(Mode.RECOVERY_STAND)))))
    for k, (t_stop, _, before) in enumerate(plan):
        if before is not None:
            timeline.append(remote(before[0], **before[1]))
        timeline += [remote(t_stop, EStop=1), remote(t_stop + ESTOP_S, EStop=0, Mode=int(Mode.PASSIVE), VelX=0.0)]
        if k < 2:  # back to the stand for the next one
            timeline.append(stand_request(t_stop + 0.5))
    timeline.append(stand_request(11.5))
    return quad_scenario(
        "quad-estop", "E-stop flicked for 60 ms in STAND_UP, BALANCE_STAND, LOCOMOTION and RECOVERY_STAND, "
                      "re-armed and asked again after each", 16.0, standing, timeline,
        (estops_make_passive(tuple(mode for _, mode, _ in plan)), upright_at_end()))


def offline_makes_passive(device: str, t_fault: float) -> Check:
    """After ``device`` goes silent: PASSIVE within OFFLINE_S + one control period, soft-damped commands to the end,
    and the heartbeat counts a device offline."""
    limit = OFFLINE_S + PERIOD_S

    def fn(run: RunData):
        t_passive = first_mode(run, int(Mode.PASSIVE), t_fault)
        if t_passive is None:
            return False, f"never PASSIVE after {device} went silent"
        damped, note = _passive_note(run, t_passive, np.inf)
        hb = run.heartbeat
        counted = int(np.max(hb["OfflineCount"][hb["t"] >= t_passive], initial=0))
        latency = t_passive - t_fault
        ok = latency <= limit + 1e-9 and damped and counted >= 1 and _mode_before(run, t_fault) != int(Mode.PASSIVE)
        return ok, f"PASSIVE {latency * 1000:.0f} ms after the fault, {note}; {counted} offline in the heartbeat"

    return Check(f"{device} silent: passive within {limit * 1000:.0f} ms, soft-damped", fn)


def offline_joint_scenario(device: str = "RL_calf") -> Scenario:
    if device not in DEVICES:
        raise ValueError(f"no device {device!r}; known: {', '.join(DEVICES)}")
    t_fault = STAND_S + 0.5
    return quad_scenario(
        "quad-offline-joint", f"balance stand; {device} goes silent at {t_fault:g} s", t_fault + 2.0, standing,
        timeline=(stand_request(), *faults.silent(device, t_fault, devices=DEVICES)),
        checks=(offline_makes_passive(device, t_fault),))


SCENARIOS = (estop_scenario(), offline_joint_scenario())
