"""The quadruped's mode machine: every transition of the table, the E-stop and a device
fault from every mode, and the stop latch (docs/quadruped-control.md, mode table)."""
from __future__ import annotations

import dataclasses

import pytest

from wheelleg.controller.quadruped.modes import (ENABLED, TRANSITIONS, Inputs, Mode, latched_after, next_mode,
                                                 requested_mode)

M = Mode
CALM = Inputs(request=M.PASSIVE, estop=False, devices_ok=True, armed=True, upright=True, fallen=False,
              motion_done=False, gait_settled=False)


def given(**changes) -> Inputs:
    return dataclasses.replace(CALM, **changes)


# (from, inputs, expected): one case per transition of the table, and the cases that must not move
CASES = [
    # passive: what starts the motors
    (M.PASSIVE, given(request=M.STAND_UP), M.STAND_UP),
    (M.PASSIVE, given(request=M.BALANCE_STAND), M.STAND_UP),
    (M.PASSIVE, given(request=M.LOCOMOTION), M.STAND_UP),
    (M.PASSIVE, given(request=M.STAND_UP, upright=False), M.RECOVERY_STAND),
    (M.PASSIVE, given(request=M.LOCOMOTION, upright=False), M.RECOVERY_STAND),
    (M.PASSIVE, given(request=M.RECOVERY_STAND), M.RECOVERY_STAND),
    (M.PASSIVE, given(request=M.RECOVERY_STAND, upright=False), M.RECOVERY_STAND),
    # and what keeps them off
    (M.PASSIVE, given(request=M.STAND_UP, armed=False), M.PASSIVE),
    (M.PASSIVE, given(request=M.RECOVERY_STAND, armed=False), M.PASSIVE),
    (M.PASSIVE, given(request=M.STAND_UP, devices_ok=False), M.PASSIVE),
    (M.PASSIVE, given(request=M.STAND_UP, estop=True), M.PASSIVE),
    (M.PASSIVE, given(request=M.PASSIVE), M.PASSIVE),
    # getting up
    (M.STAND_UP, given(request=M.STAND_UP), M.STAND_UP),
    (M.STAND_UP, given(request=M.STAND_UP, motion_done=True), M.STAND_UP),  # holds the stand it reached
    (M.STAND_UP, given(request=M.BALANCE_STAND), M.STAND_UP),  # not before the trajectory ends
    (M.STAND_UP, given(request=M.BALANCE_STAND, motion_done=True), M.BALANCE_STAND),
    (M.STAND_UP, given(request=M.LOCOMOTION, motion_done=True), M.BALANCE_STAND),  # walks from a balance stand
    (M.STAND_UP, given(request=M.RECOVERY_STAND), M.RECOVERY_STAND),
    (M.STAND_UP, given(request=M.STAND_UP, fallen=True), M.RECOVERY_STAND),
    (M.RECOVERY_STAND, given(request=M.RECOVERY_STAND), M.RECOVERY_STAND),
    (M.RECOVERY_STAND, given(request=M.RECOVERY_STAND, motion_done=True), M.RECOVERY_STAND),
    (M.RECOVERY_STAND, given(request=M.BALANCE_STAND, motion_done=True), M.BALANCE_STAND),
    (M.RECOVERY_STAND, given(request=M.LOCOMOTION, motion_done=True), M.BALANCE_STAND),
    (M.RECOVERY_STAND, given(request=M.LOCOMOTION, fallen=True), M.RECOVERY_STAND),  # it is lying: no restart
    # on the feet
    (M.BALANCE_STAND, given(request=M.BALANCE_STAND), M.BALANCE_STAND),
    (M.BALANCE_STAND, given(request=M.STAND_UP), M.BALANCE_STAND),
    (M.BALANCE_STAND, given(request=M.LOCOMOTION), M.LOCOMOTION),
    (M.BALANCE_STAND, given(request=M.RECOVERY_STAND), M.RECOVERY_STAND),
    (M.BALANCE_STAND, given(request=M.BALANCE_STAND, fallen=True), M.RECOVERY_STAND),
    (M.LOCOMOTION, given(request=M.LOCOMOTION), M.LOCOMOTION),
    (M.LOCOMOTION, given(request=M.BALANCE_STAND), M.LOCOMOTION),  # not with a foot in the air
    (M.LOCOMOTION, given(request=M.BALANCE_STAND, gait_settled=True), M.BALANCE_STAND),
    (M.LOCOMOTION, given(request=M.STAND_UP, gait_settled=True), M.BALANCE_STAND),
    (M.LOCOMOTION, given(request=M.RECOVERY_STAND), M.RECOVERY_STAND),
    (M.LOCOMOTION, given(request=M.LOCOMOTION, fallen=True), M.RECOVERY_STAND),
    # asked for passive: every enabled mode goes
    *[(mode, given(request=M.PASSIVE, motion_done=True), M.PASSIVE) for mode in ENABLED],
]


@pytest.mark.parametrize("mode,inputs,expected", CASES,
                         ids=[f"{m.name}-{i.request.name}-{e.name}-{n}" for n, (m, i, e) in enumerate(CASES)])
def test_transition(mode, inputs, expected):
    assert next_mode(mode, inputs) == expected


def _rows_taken() -> set[int]:
    """Which rows of TRANSITIONS the cases above take."""
    taken = set()
    for mode, inputs, _ in CASES:
        for row, (sources, condition, _target) in enumerate(TRANSITIONS):
            if (sources == "*" or mode in sources) and condition(mode, inputs):
                taken.add(row)
                break
    return taken


def test_the_cases_take_every_row_of_the_table_but_the_two_stops():
    stops = {0, 1}  # E-stop and device faults: the tests below, from every mode
    assert _rows_taken() | stops == set(range(len(TRANSITIONS)))


@pytest.mark.parametrize("mode", list(Mode))
@pytest.mark.parametrize("asked", list(Mode))
def test_the_estop_ends_every_mode_whatever_is_asked(mode, asked):
    assert next_mode(mode, given(request=asked, estop=True, motion_done=True)) == M.PASSIVE


@pytest.mark.parametrize("mode", sorted(ENABLED))
@pytest.mark.parametrize("asked", list(Mode))
def test_a_missing_device_ends_every_enabled_mode(mode, asked):
    assert next_mode(mode, given(request=asked, devices_ok=False, motion_done=True)) == M.PASSIVE


def test_the_latch_holds_until_the_remote_asks_for_passive():
    walk = given(request=M.LOCOMOTION)
    latched = latched_after(False, M.LOCOMOTION, M.PASSIVE, dataclasses.replace(walk, estop=True))
    assert latched
    # E-stop released, switch still on walk: stays latched, stays passive
    latched = latched_after(latched, M.PASSIVE, M.PASSIVE, walk)
    assert latched and next_mode(M.PASSIVE, dataclasses.replace(walk, armed=not latched)) == M.PASSIVE
    # the switch back to passive re-arms; then walking asks for a stand-up first
    latched = latched_after(latched, M.PASSIVE, M.PASSIVE, given(request=M.PASSIVE))
    assert not latched
    assert next_mode(M.PASSIVE, dataclasses.replace(walk, armed=True)) == M.STAND_UP


def test_an_offline_motor_latches_but_power_up_silence_does_not():
    silent = given(request=M.STAND_UP, devices_ok=False)
    assert latched_after(False, M.BALANCE_STAND, M.PASSIVE, silent)
    assert not latched_after(False, M.PASSIVE, M.PASSIVE, silent)  # nothing heard yet at power-up
    # the remote's passive with a device still missing does not re-arm
    assert latched_after(True, M.PASSIVE, M.PASSIVE, given(request=M.PASSIVE, devices_ok=False))


def test_a_requested_passive_does_not_latch():
    assert not latched_after(False, M.BALANCE_STAND, M.PASSIVE, given(request=M.PASSIVE))


def test_an_unknown_request_asks_for_passive():
    assert requested_mode(3) == M.LOCOMOTION
    assert requested_mode(7) == M.PASSIVE
