"""The operating-mode machine: E-stop wins, re-enable only on command."""

from wheelleg.controller.modes import ENABLED, Inputs, Mode, Switch, next_mode

CALM = Inputs(switch=Switch.STAND, devices_ok=True, reenable=False, jump=False, fallen=False,
              stood_up=False, off_ground=False, jump_done=False, can_rise=True)


def test_idle_rises_when_the_remote_asks_and_all_is_well():
    assert next_mode(Mode.IDLE, CALM) == Mode.STAND_UP
    assert next_mode(Mode.IDLE, CALM._replace(devices_ok=False)) == Mode.IDLE
    assert next_mode(Mode.IDLE, CALM._replace(switch=Switch.ESTOP)) == Mode.ESTOP


def test_estop_from_every_mode():
    for mode in Mode:
        assert next_mode(mode, CALM._replace(switch=Switch.ESTOP)) == Mode.ESTOP


def test_offline_device_disables_every_running_mode():
    for mode in ENABLED:
        assert next_mode(mode, CALM._replace(devices_ok=False)) == Mode.DISABLED


def test_disabled_comes_back_only_on_reenable():
    assert next_mode(Mode.DISABLED, CALM) == Mode.DISABLED
    assert next_mode(Mode.DISABLED, CALM._replace(reenable=True)) == Mode.STAND_UP
    assert next_mode(Mode.DISABLED, CALM._replace(reenable=True, devices_ok=False)) == Mode.DISABLED


def test_stand_up_then_balance_then_move_and_back():
    assert next_mode(Mode.STAND_UP, CALM._replace(stood_up=True)) == Mode.BALANCE
    assert next_mode(Mode.BALANCE, CALM._replace(switch=Switch.MOVE)) == Mode.MOVE
    assert next_mode(Mode.MOVE, CALM) == Mode.BALANCE


def test_fall_turns_torque_off():
    assert next_mode(Mode.BALANCE, CALM._replace(fallen=True)) == Mode.FALLEN
    assert Mode.FALLEN not in ENABLED
