"""Campaigns (hil/campaign/, `wheelleg campaign`): draws, journal, report, resume, bad input.

The machinery runs here on a fake rig in threads (fake_run: a run passes when
|com_x_m| < 0.02); test_campaign_rig.py runs the real rig on the local cluster.
"""
from __future__ import annotations

import io
import json
import re
from pathlib import Path

import numpy as np
import pytest

from wheelleg.hil import cli
from wheelleg.hil.campaign import analysis, execution, journal, sampling
from wheelleg.hil.campaign.progress import Progress
from wheelleg.hil.commands import campaign

RUNS_SEEN: list = []  # (scenario, sample) of every fake run, in the order they ran
BROKEN: set = set()  # (scenario, sample) the fake rig cannot run (its row has an error)


def fake_run(job: sampling.Job, settings: execution.RunSettings) -> dict:
    """A stand-in for the rig: writes a "trace", passes when |com_x_m| < 0.02 m."""
    RUNS_SEEN.append((job.scenario, job.sample))
    where = execution.run_dir(job, settings)
    where.mkdir(parents=True, exist_ok=True)
    (where / f"{job.scenario}.mcap").write_bytes(b"trace")
    offset = abs(job.overrides.get("com_x_m", 0.0))
    if (job.scenario, job.sample) in BROKEN:
        return execution.finish_files({**execution.failed_row(job, "RuntimeError: broken"), "wall_s": 0.0},
                                      job, settings)
    row = execution.failed_row(job, None)
    row["checks"] = [{"name": "drift < 5 cm", "passed": offset < 0.02, "figure": offset * 3000,
                      "detail": f"max drift {offset * 3000:.1f} cm (limit 5)"}]
    row["passed"] = offset < 0.02
    row["wall_s"] = 0.01
    return execution.finish_files(row, job, settings)


def run_campaign(argv: list[str]) -> int:
    args = cli.build_parser().parse_args(["campaign", *argv])
    return campaign.run(args, runner=fake_run, processes=False)


def rows_without_wall_time(out) -> list[dict]:
    """results.jsonl's rows less their wall times, with the campaign directory as DIR."""
    text = (out / "results.jsonl").read_text().replace(str(out), "DIR")
    rows = [json.loads(line) for line in text.splitlines()]
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


# -- sampling ------------------------------------------------------------------------------
def test_draws_are_uniform_in_range_and_a_pure_function_of_seed_sample_and_key():
    ranges = {"com_x_m": (-0.03, 0.03), "friction": (0.5, 1.5)}
    draws = [sampling.draw_overrides(7, i, ranges) for i in range(200)]
    x = np.array([d["com_x_m"] for d in draws])
    assert x.min() >= -0.03 and x.max() <= 0.03 and x.std() > 0.015  # uniform std 0.0173
    assert sampling.draw_overrides(7, 5, ranges) == draws[5]
    assert sampling.draw_overrides(7, 5, {"com_x_m": (-0.03, 0.03)})["com_x_m"] == draws[5]["com_x_m"]
    assert sampling.draw_overrides(8, 5, ranges) != draws[5]


def test_plan_gives_each_sample_one_seed_and_one_set_of_overrides_in_every_scenario():
    jobs = sampling.plan(["balance", "drive"], 3, 1, {"com_x_m": (-0.01, 0.01)})
    assert [(j.scenario, j.sample) for j in jobs] == [(s, i) for i in range(3) for s in ("balance", "drive")]
    assert jobs[0].seed == jobs[1].seed != jobs[2].seed
    assert jobs[0].overrides == jobs[1].overrides != jobs[2].overrides
    assert sampling.plan(["balance"], 5, 1, {"com_x_m": (-0.01, 0.01)})[:3] == jobs[::2]


def test_tolerance_v1_preset_is_issue_12s_box():
    box = sampling.PRESETS["tolerance-v1"]
    assert box["body_mass_scale"] == (0.8, 1.4) and box["com_x_m"] == (-0.03, 0.03)
    assert box["com_z_m"] == (-0.02, 0.02) and box["friction"] == (0.5, 1.5)
    assert box["hip_kt_scale"] == box["wheel_kt_scale"] == (0.85, 1.15)
    assert box["imu_tilt_pitch_deg"] == box["imu_tilt_roll_deg"] == (-3.0, 3.0)
    assert box["imu_gyro_bias"] == (-0.05, 0.05) and box["supply_voltage_v"] == (22.0, 26.0)
    assert box["feedback_delay_s"] == box["command_delay_s"] == (0.0, 0.002)
    ranges = sampling.campaign_ranges("tolerance-v1", ["friction=0.3..0.4"])
    assert ranges["friction"] == (0.3, 0.4) and ranges["com_x_m"] == (-0.03, 0.03)


def _documented_box() -> dict:
    """docs/robot.md's tolerance table: `key` -> (low, high), from its "low .. high" column."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "robot.md").read_text()
    section = text[text.index("## The tolerance box"):]
    rows = re.findall(r"^\| (`[^|]+) \| (-?[0-9.]+) \.\. (-?[0-9.]+)", section, flags=re.M)
    return {key: (float(low), float(high)) for keys, low, high in rows for key in re.findall(r"`([a-z0-9_]+)`", keys)}


def test_tolerance_preset_is_the_sourced_box_of_docs_robot_md():
    from wheelleg.emulators.overrides import OVERRIDES

    box = sampling.PRESETS["tolerance"]
    assert _documented_box() == box  # every key with its source, and nothing undocumented drawn
    for key, (low, high) in box.items():
        spec = OVERRIDES[key]
        assert spec.low <= low < high <= spec.high, key
    for side_key in ("hip_frictionloss", "hip_kt_scale", "wheel_frictionloss", "wheel_kt_scale"):
        assert f"{side_key}_left" in box and f"{side_key}_right" in box and side_key not in box  # drawn apart
    assert len([k for k in box if k.startswith("hip_zero_offset_")]) == 4
    drawn = sampling.draw_overrides(1, 0, box)
    assert drawn["hip_frictionloss_left"] != drawn["hip_frictionloss_right"]


@pytest.mark.parametrize("text", ["com_x_m=0.03..-0.03", "com_x_m=0.1", "com_x_m", "=1..2", "com_x_m=a..b",
                                  "com_x_m=0..inf"])
def test_bad_vary_is_a_one_line_error(text):
    with pytest.raises(ValueError) as err:
        sampling.parse_range(text)
    assert "\n" not in str(err.value) and text in str(err.value)


# -- analysis ------------------------------------------------------------------------------
def synthetic_rows(n: int = 60) -> list[dict]:
    """Failures wherever |com_x_m| > 0.02 (both ends), friction irrelevant."""
    rng = np.random.default_rng(0)
    rows = []
    for i in range(n):
        x, mu = rng.uniform(-0.03, 0.03), rng.uniform(0.5, 1.5)
        rows.append({"scenario": "balance", "sample": i, "passed": abs(x) <= 0.02,
                     "overrides": {"com_x_m": x, "friction": mu}, "checks": []})
    return rows


def test_separation_finds_the_override_failures_cluster_on_even_at_both_ends():
    ranges = {"com_x_m": (-0.03, 0.03), "friction": (0.5, 1.5)}
    found = analysis.clustering(synthetic_rows(), ranges)
    assert [c.key for c in found] == ["com_x_m", "friction"]
    assert found[0].separation == pytest.approx(1.0) and found[1].separation < 0.4
    edges = found[0].bin_failures
    assert edges[0][0] == edges[0][1] > 0 and edges[9][0] == edges[9][1] > 0  # every run at the ends fails
    assert edges[4][0] == edges[5][0] == 0 and sum(n for _, n in edges) == 60


def test_separation_is_undefined_without_failures():
    assert np.isnan(analysis.separation(np.arange(5.0), np.zeros(5, bool), 2.0))


# -- the command on a fake rig ---------------------------------------------------------------
@pytest.mark.slow
def test_campaign_journals_every_run_keeps_failing_traces_and_reports(tmp_path):
    out = tmp_path / "c"
    code = run_campaign(["balance", "drive", "--samples", "12", "--vary", "com_x_m=-0.03..0.03",
                         "--seed", "3", "--out", str(out), "-q"])
    rows = rows_without_wall_time(out)
    assert [(r["scenario"], r["sample"]) for r in rows] == [(s, i) for s in ("balance", "drive") for i in range(12)]
    failing = [r for r in rows if not r["passed"]]
    assert code == (1 if failing else 0) and failing and len(failing) < len(rows)
    for r in rows:
        trace = out / "runs" / r["scenario"] / f"sample-{r['sample']:04d}" / f"{r['scenario']}.mcap"
        assert trace.exists() == (not r["passed"])
        assert f"--seed {r['seed']}" in r["rerun"] and f"--plant com_x_m={r['overrides']['com_x_m']!r}" in r["rerun"]
    text = (out / "report.md").read_text()
    assert f"| balance | 12 | {sum(r['passed'] for r in rows[:12])} |" in text
    assert failing[0]["rerun"].replace("DIR", str(out)) in text and (out / "pass_fail.png").stat().st_size > 1000
    assert "| balance | com_x_m |" in text


def test_same_command_same_results_and_a_resumed_campaign_runs_only_what_is_missing(tmp_path):
    argv = ["balance", "--samples", "6", "--vary", "com_x_m=-0.03..0.03", "-q"]
    run_campaign([*argv, "--out", str(tmp_path / "a")])
    run_campaign([*argv, "--out", str(tmp_path / "b")])
    assert rows_without_wall_time(tmp_path / "a") == rows_without_wall_time(tmp_path / "b")

    journal_path = tmp_path / "b" / "results.jsonl"
    lines = journal_path.read_text().splitlines(keepends=True)
    journal_path.write_text("".join(lines[:2]) + lines[2][:20])  # killed while writing the third row
    RUNS_SEEN.clear()
    run_campaign([*argv, "--out", str(tmp_path / "b")])
    assert sorted(RUNS_SEEN) == [("balance", i) for i in range(2, 6)]
    assert rows_without_wall_time(tmp_path / "a") == rows_without_wall_time(tmp_path / "b")

    RUNS_SEEN.clear()  # more samples: only the new ones run
    BROKEN.add(("balance", 7))
    run_campaign(["balance", "--samples", "8", "--vary", "com_x_m=-0.03..0.03", "-q", "--out", str(tmp_path / "b")])
    assert sorted(RUNS_SEEN) == [("balance", 6), ("balance", 7)]
    BROKEN.clear()  # a run that could not run is run again on resume
    RUNS_SEEN.clear()
    run_campaign(["balance", "--samples", "8", "--vary", "com_x_m=-0.03..0.03", "-q", "--out", str(tmp_path / "b")])
    assert RUNS_SEEN == [("balance", 7)]
    assert [r["error"] for r in rows_without_wall_time(tmp_path / "b")] == [None] * 8


@pytest.mark.parametrize("argv", [
    ["no-such-scenario"], ["balance", "--vary", "com_x_m=0.03..-0.03"], ["balance", "--preset", "nope"],
    ["balance", "--vary", "com_x_m"], ["balance", "--samples", "0"], ["balance", "--duration", "-1"],
    ["balance", "--vary", "friction=0.01..1"],
])
def test_bad_input_is_a_one_line_error_exit_2(tmp_path, capsys, argv):
    assert run_campaign([*argv, "--out", str(tmp_path / "c"), "-q"]) == 2
    printed = capsys.readouterr().out
    assert printed.count("\n") == 1 and printed.startswith("campaign: ")
    assert not (tmp_path / "c" / "results.jsonl").exists()


@pytest.mark.parametrize("vary", ["no_such_key=0..1", "friction=-1..1"])
def test_a_key_or_value_the_plant_refuses_is_a_one_line_error_exit_2(tmp_path, capsys, vary):
    assert run_campaign(["balance", "--vary", vary, "--out", str(tmp_path / "c"), "-q"]) == 2
    printed = capsys.readouterr().out
    assert printed.count("\n") == 1 and vary.split("=")[0] in printed


def test_another_campaign_in_the_same_directory_is_refused(tmp_path, capsys):
    out = str(tmp_path / "c")
    assert run_campaign(["balance", "--samples", "2", "--out", out, "-q"]) == 0
    assert run_campaign(["balance", "--samples", "2", "--seed", "1", "--out", out, "-q"]) == 2
    assert "seed" in capsys.readouterr().out


def test_a_torn_last_row_is_dropped(tmp_path):
    (tmp_path / "results.jsonl").write_text('{"scenario": "balance", "sample": 0}\n{"scenario": "bal')
    log = journal.Journal(tmp_path)
    assert list(log.rows) == [("balance", 0)]
    log.append({"scenario": "balance", "sample": 1})
    assert len((tmp_path / "results.jsonl").read_text().splitlines()) == 2


# -- progress --------------------------------------------------------------------------------
class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_only_on_a_terminal_and_not_when_quiet():
    plain, quiet, tty = io.StringIO(), Terminal(), Terminal()
    for stream, enabled in ((plain, True), (quiet, False), (tty, True)):
        bar = Progress(4, done=1, enabled=enabled, stream=stream)
        bar.update(passed=False)
        bar.close()
    assert plain.getvalue() == quiet.getvalue() == ""
    assert "2/4 runs, 1 failed" in tty.getvalue()
