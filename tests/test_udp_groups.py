"""tests/udp_groups.py: a udp_multicast group is one test's alone on the machine while it holds it
(a pid-seeded draw per worker let two xdist workers run ``test_programs`` on one group)."""
import subprocess
import sys
from pathlib import Path

import udp_groups
from udp_groups import claimed_pair

HERE = Path(__file__).resolve().parent


def test_two_workers_of_a_session_start_apart():
    gw0, gw1 = udp_groups.candidates("gw0"), udp_groups.candidates("gw1")
    assert sorted(gw0) == sorted(gw1)  # the same groups, each worker from its own start
    assert set(gw0[:udp_groups.WORKER_SPACING]).isdisjoint(gw1[:udp_groups.WORKER_SPACING])
    assert udp_groups.worker_number("") == 0 and udp_groups.worker_number("gw3") == 3


def test_a_held_group_is_not_given_again_until_it_is_released(tmp_path):
    with claimed_pair("gw0", tmp_path) as first:
        with claimed_pair("gw0", tmp_path) as second:  # same worker, same start: the next pair
            assert second != first
    with claimed_pair("gw0", tmp_path) as again:
        assert again == first


def test_a_group_held_by_another_process_is_passed_over(tmp_path):
    """Another session's worker on the same machine (same worker name, so the same start)."""
    code = ("import sys, udp_groups\n"
            f"with udp_groups.claimed_pair('gw1', udp_groups.Path({str(tmp_path)!r})) as base:\n"
            "    print(base, flush=True); sys.stdin.read()\n")
    other = subprocess.Popen([sys.executable, "-c", code], cwd=HERE, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             text=True)
    try:
        theirs = int(other.stdout.readline())
        with claimed_pair("gw1", tmp_path) as ours:
            assert ours != theirs
    finally:
        other.communicate("")
