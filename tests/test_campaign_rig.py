"""`wheelleg campaign` end to end: the real rig on a local Dask cluster of worker processes.

Short runs (0.3 s each): what is checked is the machinery, not the robot.
"""
from __future__ import annotations

import json
import shlex

import pytest

from wheelleg.hil import cli

pytestmark = pytest.mark.slow  # scheduled first (tests/conftest.py)

CAMPAIGN = ["campaign", "balance", "--samples", "3", "--seed", "5", "--duration", "0.3",
            "--vary", "com_x_m=-0.03..0.03", "--vary", "feedback_delay_s=0..0.002",
            "--workers", "1", "--keep-passing", "-q"]


def rows(out) -> list[dict]:
    text = (out / "results.jsonl").read_text().replace(str(out), "DIR")
    return [{k: v for k, v in json.loads(line).items() if k not in ("wall_s", "cpu_s")} for line in text.splitlines()]


def test_a_campaign_run_is_the_run_its_rerun_command_gives_and_the_same_command_the_same_rows(tmp_path):
    first, second = tmp_path / "first", tmp_path / "second"
    code = cli.main([*CAMPAIGN, "--out", str(first)])
    got = rows(first)
    assert code == (0 if all(r["passed"] for r in got) else 1)
    assert [r["sample"] for r in got] == [0, 1, 2] and all(r["error"] is None and r["checks"] for r in got)
    assert len({r["seed"] for r in got}) == 3 and len({r["overrides"]["com_x_m"] for r in got}) == 3

    # the last run shared its worker process with two runs before it; alone it gives the same bytes
    last = json.loads((first / "results.jsonl").read_text().splitlines()[-1])
    argv = shlex.split(last["rerun"])
    assert argv[:2] == ["wheelleg", "run"] and f"com_x_m={last['overrides']['com_x_m']!r}" in argv
    assert cli.main([*argv[1:], "--no-plot"]) in (0, 1)
    run_dir = first / "runs" / "balance" / "sample-0002"
    assert (run_dir / "rerun" / "balance.log").read_bytes() == (run_dir / "balance.log").read_bytes()

    cli.main([*CAMPAIGN, "--workers", "2", "--out", str(second)])
    assert rows(second) == got
