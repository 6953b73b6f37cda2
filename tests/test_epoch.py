"""``--epoch SECONDS``: the candump log's start time, in the trace's metadata and its rerun command."""
from __future__ import annotations

import json

import pytest

from wheelleg.hil import cli
from wheelleg.hil.campaign import execution, sampling
from wheelleg.hil.commands import campaign
from wheelleg.hil.commands.run import execute
from wheelleg.hil.record.candump import read_candump
from wheelleg.hil.record.run_metadata import epoch_text, parse_epoch, rerun_command
from wheelleg.hil.record.trace import TraceReader

EPOCH = "1700000000.123456"  # whole microseconds: candump's resolution


def _run(out, *extra):
    args = cli.build_parser().parse_args(["run", "balance", "--duration", "0.1", "--out", str(out), "--no-plot",
                                          "-q", *extra])
    outcome, _, _ = execute(args)
    return outcome


def test_epoch_shifts_every_stamp_of_the_log_and_lands_in_the_metadata(tmp_path):
    plain, shifted = _run(tmp_path / "plain"), _run(tmp_path / "shifted", "--epoch", EPOCH)
    before, after = list(read_candump(plain.log_path)), list(read_candump(shifted.log_path))
    assert len(after) == len(before) > 500
    assert before[0].t_ns < 1_000_000  # the default: the run's own time, from 0
    assert {b.t_ns - a.t_ns for a, b in zip(before, after)} == {parse_epoch(EPOCH)}
    assert [(a.channel, a.arbitration_id, a.data) for a in before] == \
        [(b.channel, b.arbitration_id, b.data) for b in after]
    run = TraceReader(shifted.trace_path).metadata["run"]
    assert run["epoch_s"] == EPOCH and TraceReader(plain.trace_path).metadata["run"]["epoch_s"] == "0"
    assert f"--epoch {EPOCH}" in rerun_command(run)
    assert "--epoch" not in rerun_command(TraceReader(plain.trace_path).metadata["run"])
    # the trace keeps the run's time: its frames are where the unshifted run has them
    assert [f.t_ns for f in TraceReader(shifted.trace_path).frames()] == \
        [f.t_ns for f in TraceReader(plain.trace_path).frames()]
    # the rerun command gives the same bytes
    again = _run(tmp_path / "again", *rerun_command(run).split()[3:])
    assert again.log_path.read_bytes() == shifted.log_path.read_bytes()


@pytest.mark.parametrize("text", ["-1", "abc", "1.0000000001", "nan", "inf"])
def test_a_bad_epoch_is_a_usage_error(text, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["run", "balance", "--epoch", text, "--out", str(tmp_path)])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "--epoch" in err[-1] and "epoch" in err[-1].split("--epoch", 1)[1]


def test_epoch_text_reads_back_exactly():
    for ns in (0, 1, 999_999_999, 1_700_000_000_123_456_000, 10**19 + 7):
        assert parse_epoch(epoch_text(ns)) == ns
    assert epoch_text(1_700_000_000_250_000_000) == "1700000000.25" and epoch_text(5 * 10**9) == "5"


EPOCHS_SEEN: list = []  # the RigConfig.epoch_ns each fake campaign run would have run with


def fake_run(job: sampling.Job, settings: execution.RunSettings) -> dict:
    """A stand-in for the rig (module level: Dask ships it by name): passes, notes its epoch."""
    EPOCHS_SEEN.append(execution.rig_config(job.seed, job.overrides, settings.epoch_ns).epoch_ns)
    return execution.finish_files({**execution.failed_row(job, None), "passed": True, "wall_s": 0.0}, job, settings)


def test_a_campaign_passes_its_epoch_to_every_run_and_rerun_command(tmp_path):
    EPOCHS_SEEN.clear()
    args = cli.build_parser().parse_args(["campaign", "balance", "--samples", "2", "--out", str(tmp_path),
                                          "--epoch", EPOCH, "--duration", "0.1", "-q"])
    assert campaign.run(args, runner=fake_run, processes=False) == 0
    assert EPOCHS_SEEN == [parse_epoch(EPOCH)] * 2
    rows = [json.loads(line) for line in (tmp_path / "results.jsonl").read_text().splitlines()]
    assert all(f"--epoch {EPOCH}" in row["rerun"] for row in rows)
    assert f"--epoch {EPOCH}" in campaign.canonical_command(args)
    plain = cli.build_parser().parse_args(["campaign", "balance", "--out", str(tmp_path)])
    assert "epoch_s" not in campaign.campaign_spec(plain)  # a directory from before --epoch resumes
