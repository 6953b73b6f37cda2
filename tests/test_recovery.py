"""The recovery stand table (controller/recovery.py)."""
import pytest

from wheelleg.controller import params as P
from wheelleg.controller.recovery import PHASES, Phase, RecoverySequencer, RecoveryView, next_phase

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
        cmd = seq.step((0.12, 0.12), 0.5, 0.0)
        ticks += 1
        if cmd.pitch is not None:
            assert 0.0 <= cmd.pitch <= last  # never overshoots, never goes back
    assert ticks == pytest.approx(0.8 / (P.RECOVERY_PITCH_RATE * DT), abs=3)
    seq.stop()
    assert not seq.active and seq.step((0.12, 0.12), 0.0, 0.0).phase == Phase.DONE
