"""tools/bench.py's reference check: it names the first line where a candump log differs; the tools' scenario argument."""
import pytest

from tools import known_scenario, lockstep_ceiling
from tools.bench import first_difference


def test_equal_logs_have_no_difference():
    assert first_difference([b"a", b"b"], [b"a", b"b"]) is None


def test_the_first_differing_line_is_named_with_both_texts():
    message = first_difference([b"a", b"x", b"y"], [b"a", b"b", b"c"])
    assert message.startswith("line 2:") and "'b'" in message and "'x'" in message


def test_a_shorter_log_differs_where_it_ends():
    assert first_difference([b"a"], [b"a", b"b"]) == "line 2: expected 2 lines, got 1"


def test_a_tool_told_an_unknown_scenario_exits_2_with_the_known_ones(capsys):
    assert known_scenario("quadruped/quad-trot") == "quadruped/quad-trot"
    with pytest.raises(SystemExit) as exc:
        lockstep_ceiling.main(["nosuch"])
    assert exc.value.code == 2
    assert "no scenario 'nosuch'; known: balance" in capsys.readouterr().err


def test_mujocos_share_is_read_from_callgrind_annotates_inclusive_listing():
    from tools.loop_instructions import inclusive_in
    annotated = """--------------------------------------------------------------------------------
Ir
--------------------------------------------------------------------------------
891,936,401 (100.0%)  PROGRAM TOTALS
--------------------------------------------------------------------------------
Ir                    file:function
--------------------------------------------------------------------------------
80,812,553 ( 9.06%)  ???:mj_step [/venv/lib/python3.11/site-packages/mujoco/libmujoco.so.3.3.0]
80,700,001 ( 9.05%)  ???:mj_step1 [/venv/lib/python3.11/site-packages/mujoco/libmujoco.so.3.3.0]
"""
    assert inclusive_in(annotated, "mj_step") == 80_812_553
    assert inclusive_in(annotated, "mj_forward") is None
