"""The recovery stand table (controller/recovery.py)."""
import pytest

from wheelleg.controller import params as P
from wheelleg.controller.recovery import PHASES, Phase, RecoverySequencer, RecoveryView, next_phase, next_pitch_ref

DT = P.CONTROL_PERIOD


def test_table_rows_lead_forward_and_time_out():
    assert set(PHASES) == {Phase.TUCK, Phase.TILT_UP}
    for phase, spec in PHASES.items():
        assert spec.then > phase and spec.on_timeout > phase and spec.timeout_s > 0


def test_tuck_ends_when_the_legs_are_short_after_the_settle_time():
    short = P.RECOVERY_TUCK_LENGTH + 0.005
    assert next_phase(Phase.TUCK, RecoveryView(0.1, short, False)) == Phase.TUCK  # stale leg data at first
    assert next_phase(Phase.TUCK, RecoveryView(0.4, 0.2, False)) == Phase.TUCK
    assert next_phase(Phase.TUCK, RecoveryView(0.4, short, False)) == Phase.TILT_UP
    assert next_phase(Phase.TUCK, RecoveryView(P.RECOVERY_TUCK_TIMEOUT, 0.2, False)) == Phase.TILT_UP
    assert next_phase(Phase.TILT_UP, RecoveryView(0.5, 0.12, True)) == Phase.DONE


def test_the_pitch_set_point_ramps_from_lying_to_the_operators():
    seq = RecoverySequencer(DT)
    seq.start()
    assert seq.active
    cmd = seq.step((0.2, 0.2), 0.8, 0.0)
    assert cmd.phase == Phase.TUCK and cmd.airborne and cmd.pitch is None
    for _ in range(round(P.RECOVERY_TUCK_TIMEOUT / DT)):
        cmd = seq.step((0.12, 0.12), 0.8, 0.0)
        if cmd.phase != Phase.TUCK:
            break
    assert cmd.phase == Phase.TILT_UP and not cmd.airborne and seq.elapsed_s == pytest.approx(DT)
    assert cmd.pitch == pytest.approx(0.8 - P.RECOVERY_PITCH_RATE * DT)  # starts where the body lies
    ticks = 0
    while seq.active:
        last = cmd.pitch
        cmd = seq.step((0.12, 0.12), 0.8, 0.0)  # the body still lying: the set point ramps on alone
        ticks += 1
        if cmd.pitch is not None:
            assert 0.0 <= cmd.pitch <= last  # never overshoots, never goes back
    assert ticks == pytest.approx(0.8 / (P.RECOVERY_PITCH_RATE * DT), abs=3)
    seq.stop()
    assert not seq.active and seq.step((0.12, 0.12), 0.0, 0.0).phase == Phase.DONE


def test_a_body_rising_faster_than_the_ramp_takes_the_set_point_with_it():
    seq = RecoverySequencer(DT)
    seq.start()
    while seq.phase == Phase.TUCK:
        seq.step((0.12, 0.12), 0.8, 0.0)
    assert seq.pitch_ref == pytest.approx(0.8 - P.RECOVERY_PITCH_RATE * DT)
    cmd = seq.step((0.12, 0.12), 0.3, 0.0)  # the body rose past the set point
    assert cmd.pitch == pytest.approx(0.3 - P.RECOVERY_PITCH_RATE * DT)


STEP = 0.01


@pytest.mark.parametrize("ref, measured, target, expected", [
    (0.8, 0.8, 0.0, 0.8 - STEP),  # on the set point: the ramp
    (0.8, 0.9, 0.0, 0.8 - STEP),  # the body behind the set point (sank back): the ramp, not back to it
    (0.8, 0.3, 0.0, 0.3 - STEP),  # the body ahead: on from where it is
    (0.8, 0.005, 0.0, 0.0),  # within a step of the target: the target, no overshoot
    (0.8, -0.1, 0.0, 0.8 - STEP),  # the body past the target: the ramp, not past the target
    (-0.8, -0.3, 0.0, -0.3 + STEP),  # lying nose up, the same mirrored
    (-0.8, -0.9, 0.0, -0.8 + STEP),
    (0.02, 0.5, 0.0, 0.02 - STEP),  # never away from the target
])
def test_next_pitch_ref(ref, measured, target, expected):
    assert next_pitch_ref(ref, measured, target, STEP) == pytest.approx(expected)
