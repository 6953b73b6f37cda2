"""The jump phase table (controller/jump.py) and the modes it adds."""
from dataclasses import replace

from wheelleg.controller import params as P
from wheelleg.controller.jump import PHASES, JumpSequencer, JumpView, Phase, next_phase
from wheelleg.controller.modes import Inputs, Mode, Switch, next_mode

DT = P.CONTROL_PERIOD


def test_every_phase_but_done_has_a_row_and_leads_forward():
    assert set(PHASES) == set(Phase) - {Phase.DONE}
    for phase, spec in PHASES.items():
        assert spec.then > phase and spec.on_timeout > phase  # no loops: a jump always ends
        assert spec.timeout_s > 0


def test_phase_exits():
    assert next_phase(Phase.SQUAT, JumpView(0.5, 0.125, True)) == Phase.THRUST
    assert next_phase(Phase.SQUAT, JumpView(0.01, 0.125, True)) == Phase.SQUAT  # settle first
    assert next_phase(Phase.SQUAT, JumpView(0.5, 0.16, True)) == Phase.SQUAT
    assert next_phase(Phase.SQUAT, JumpView(P.JUMP_SQUAT_TIMEOUT, 0.16, True)) == Phase.THRUST
    assert next_phase(Phase.THRUST, JumpView(0.05, P.JUMP_THRUST_END_LENGTH + 0.001, True)) == Phase.RETRACT
    assert next_phase(Phase.RETRACT, JumpView(0.05, P.JUMP_RETRACT_LENGTH - 0.001, False)) == Phase.FLIGHT
    assert next_phase(Phase.FLIGHT, JumpView(0.2, 0.18, False)) == Phase.FLIGHT
    assert next_phase(Phase.FLIGHT, JumpView(0.2, 0.18, True)) == Phase.LAND
    assert next_phase(Phase.LAND, JumpView(P.JUMP_LAND_TIME, 0.17, True)) == Phase.DONE


def test_sequencer_runs_a_whole_jump_and_commands_each_phase():
    seq = JumpSequencer(DT)
    seq.start()
    seen = {}
    length, touching = 0.17, True
    for _ in range(2000):
        cmd = seq.step((length, length), touching)
        seen.setdefault(cmd.phase, cmd)
        if cmd.phase == Phase.SQUAT:
            length = max(0.12, length - 0.001)
        elif cmd.phase == Phase.THRUST:
            length += 0.004
        elif cmd.phase == Phase.RETRACT:
            length, touching = length - 0.004, False
        elif cmd.phase == Phase.FLIGHT and seq.elapsed_s > 0.2:
            touching = True
        if seq.done:
            break
    assert seq.done and list(seen) == [Phase.SQUAT, Phase.THRUST, Phase.RETRACT, Phase.FLIGHT, Phase.LAND, Phase.DONE]
    assert not seen[Phase.SQUAT].airborne and seen[Phase.SQUAT].leg_length == P.JUMP_SQUAT_LENGTH
    assert seen[Phase.THRUST].leg_force > 5 * P.LEG_GRAVITY_FF  # full push at the bottom of the stroke
    assert seen[Phase.THRUST].hip_torque_limit > P.HIP_TORQUE_LIMIT
    assert seen[Phase.RETRACT].airborne and seen[Phase.RETRACT].leg_length < seen[Phase.FLIGHT].leg_length
    assert seen[Phase.FLIGHT].airborne and seen[Phase.FLIGHT].leg_length == P.JUMP_LAND_LENGTH
    assert not seen[Phase.LAND].airborne


def test_thrust_force_decays_to_gravity_at_full_stroke():
    seq = JumpSequencer(DT)
    seq.phase = Phase.THRUST
    assert seq.step((P.JUMP_THRUST_END_LENGTH - 1e-6,) * 2, True).leg_force < P.LEG_GRAVITY_FF + 1e-3


def test_a_jump_that_never_leaves_the_ground_still_ends():
    seq = JumpSequencer(DT)
    seq.start()
    for _ in range(round(5.0 / DT)):
        seq.step((0.17, 0.17), True)  # legs never move, always touching
    assert seq.done


CALM = Inputs(switch=Switch.STAND, devices_ok=True, reenable=False, jump=False, fallen=False,
              stood_up=False, off_ground=False, jump_done=False, can_rise=True)


def test_modes_for_air_and_jumps():
    assert next_mode(Mode.BALANCE, replace(CALM, off_ground=True)) == Mode.AIRBORNE
    assert next_mode(Mode.MOVE, replace(CALM, switch=Switch.MOVE, off_ground=True)) == Mode.AIRBORNE
    assert next_mode(Mode.AIRBORNE, replace(CALM, off_ground=True)) == Mode.AIRBORNE
    assert next_mode(Mode.AIRBORNE, CALM) == Mode.BALANCE
    assert next_mode(Mode.BALANCE, replace(CALM, jump=True)) == Mode.JUMP
    assert next_mode(Mode.JUMP, replace(CALM, off_ground=True)) == Mode.JUMP  # Fn ignored in a jump
    assert next_mode(Mode.JUMP, replace(CALM, jump_done=True)) == Mode.BALANCE
    assert next_mode(Mode.STAND_UP, replace(CALM, jump=True)) == Mode.STAND_UP  # no jump before standing


def test_a_tumble_in_the_air_turns_torque_off_and_estop_wins_everywhere():
    for mode in (Mode.JUMP, Mode.AIRBORNE):
        assert next_mode(mode, replace(CALM, fallen=True)) == Mode.FALLEN
        assert next_mode(mode, replace(CALM, switch=Switch.ESTOP, fallen=True)) == Mode.ESTOP
    assert next_mode(Mode.FALLEN, CALM) == Mode.FALLEN  # stays down until the operator asks
    assert next_mode(Mode.FALLEN, replace(CALM, reenable=True)) == Mode.STAND_UP
