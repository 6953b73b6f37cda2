"""The balancer's scenarios: ``balance`` and ``offline-wheel``.

Built from the rig's scenario parts (wheelleg.hil.run.scenario, .scenarios.common,
.run.faults) and judged from the trace alone: /sim/state's pitch and x, the
heartbeat's Mode (controller.Mode: 0 idle, 1 balance, 2 disabled) and the C620
currents commanded.
"""
from __future__ import annotations

import math

import numpy as np

from wheelleg.hil.run import faults
from wheelleg.hil.run.scenario import Check, RunData, Scenario, in_window
from wheelleg.hil.scenarios.common import (CURRENT_OFF_A, DEG, drift_below, first_mode, no_deadline_miss,
                                           pitch_below, remote, torque_after)
from wheelleg_balancer import description as D

ROBOT = "balancer"
BALANCE, DISABLED = 1, 2  # controller.Mode (the scenarios judge the heartbeat, not the controller's code)
DEVICES = ("left_wheel", "right_wheel", "imu", "remote")
START_LEAN_RAD = 2 * DEG  # the operator lets go of it leaning forward
FAULT_AT_S = 1.0
ESC_OFFLINE_S = 0.010  # what the balancer's owner asks of it: motors off within its ESC timeout ...
PERIOD_S = D.CONTROL_PERIOD_S  # ... plus one control period


def leaning(physics) -> None:
    physics.reset_upright(START_LEAN_RAD)


def balances(t0_s: float, t1_s: float = np.inf) -> Check:
    """The heartbeat shows BALANCE at every tick in [t0_s, t1_s)."""
    def fn(run: RunData):
        t = run.heartbeat["t"]
        modes = in_window(t, run.heartbeat["Mode"], t0_s, t1_s, "heartbeats")
        started = first_mode(run, BALANCE)
        return bool(np.all(modes == BALANCE)), (
            f"balancing from {'never' if started is None else f'{started:.3f} s'}; "
            f"{int(np.sum(modes != BALANCE))} heartbeats in another mode over {t0_s:g}-{t1_s:g} s")

    return Check(f"in BALANCE over {t0_s:g}-{t1_s:g} s", fn)


def motors_off_after_fault(device: str, bound_s: float) -> Check:
    """The heartbeat says DISABLED and every current commanded is zero from the fault + ``bound_s`` on."""
    def fn(run: RunData):
        t_f = next(e["t"] for e in run.events_of("fault_silent") if e.get("device") == device)
        disabled = first_mode(run, DISABLED, t_f)
        _, current = torque_after(run, t_f + bound_s)
        took = math.inf if disabled is None else disabled - t_f
        return took <= bound_s and current < CURRENT_OFF_A, (
            f"DISABLED {took * 1000:.1f} ms after {device} went silent (bound {bound_s * 1000:g} ms); "
            f"largest wheel current after the bound {current:.3f} A")

    return Check(f"{device} silent: DISABLED and zero current within {bound_s * 1000:g} ms", fn)


def robot_scenario(name: str, summary: str, duration_s: float, timeline=(), checks=()) -> Scenario:
    """A scenario of the balancer: it starts leaning, the remote asks for balance at once."""
    return Scenario(name, summary, duration_s, leaning, (remote(0.0, Mode=BALANCE), *timeline),
                    (*checks, no_deadline_miss()), robot=ROBOT)


SCENARIOS = (
    robot_scenario("balance", f"let go leaning {START_LEAN_RAD / DEG:g} deg forward: upright and on the spot "
                      "for 5 s", 5.0, checks=(balances(0.05), pitch_below(1.0 * DEG, 2.0),
                                              drift_below(0.10))),
    robot_scenario("offline-wheel", f"the left wheel's C620 goes silent at {FAULT_AT_S:g} s: motors off within "
                      "its timeout + one period", FAULT_AT_S + 0.3,
                      timeline=faults.silent("left_wheel", FAULT_AT_S, devices=DEVICES),
                      checks=(balances(0.05, FAULT_AT_S), motors_off_after_fault("left_wheel", ESC_OFFLINE_S + PERIOD_S))),
)
