"""Robustness margins (hil/campaign/margins.py, margin_runs.py, `wheelleg margins`).

The bisection runs here against fake pass/fail oracles and the command on a fake
rig in threads; one short real run (test_a_real_edge_...) shows a real edge.
"""
from __future__ import annotations

import json
import shlex

import pytest

from wheelleg.emulators.overrides import OVERRIDES
from wheelleg.hil import cli
from wheelleg.hil.campaign import execution, margin_runs, margins, sampling
from wheelleg.hil.commands import margins as margins_command


def passes_below(edge: float):
    """An oracle: passes while value < edge."""
    return lambda value: value < edge


# -- the bisection on one side -----------------------------------------------------------------

@pytest.mark.parametrize("edge", [0.013, 0.029, 0.047, 0.08])
def test_the_edge_lies_in_the_final_bracket_and_the_bracket_shrinks_with_runs(edge):
    widths = []
    for runs in (3, 5, 8):
        s = margins.find_edge(passes_below(edge), nominal=0.0, limit=0.1, gate=0.03, runs=runs)
        assert s.passing < edge <= s.failing  # pass just inside, fail at or past the edge
        assert len(s.probes) == runs
        widths.append(s.failing - s.passing)
    assert widths[0] > widths[1] > widths[2]


def test_the_first_probe_is_the_gate_then_the_limit_then_the_middle():
    s = margins.find_edge(passes_below(0.08), nominal=0.0, limit=0.1, gate=0.03, runs=3)
    assert [v for v, _ in s.probes] == [0.03, 0.1, pytest.approx((0.03 * 0.1) ** 0.5, rel=1e-5)]
    s = margins.find_edge(passes_below(0.02), nominal=0.0, limit=0.1, gate=0.03, runs=3)
    # the gate failed: halves toward nominal, then (0.015 passed) in ratio
    assert [v for v, _ in s.probes] == [0.03, 0.015, pytest.approx((0.015 * 0.03) ** 0.5, rel=1e-5)]


def test_below_nominal_the_search_walks_down():
    s = margins.find_edge(lambda v: v > 0.55, nominal=1.0, limit=0.2, gate=0.7, runs=6)
    assert s.failing <= 0.55 < s.passing and s.failing > 0.2
    assert s.probes[0] == (0.7, True) and s.probes[1] == (0.2, False)


def test_a_passing_limit_is_beyond_the_allowed_range_and_stops_the_search():
    s = margins.find_edge(lambda v: True, nominal=0.0, limit=0.05, gate=0.003, runs=5)
    assert s.failing is None and s.passing == 0.05 and len(s.probes) == 2
    edge = margins.edge_from(s, "above", 0.002, None)
    assert margins.edge_cell(edge, 0.0).startswith("beyond allowed range")
    assert margins.ratio_cell(edge, 0.0) == ">25.00" and not edge.flagged(0.0)


def test_no_room_on_a_side_probes_nothing_and_a_gate_past_the_limit_probes_the_limit_first():
    assert margins.find_edge(lambda v: False, nominal=0.0, limit=0.0, gate=None, runs=3).probes == []
    s = margins.find_edge(lambda v: True, nominal=1.0, limit=1.2, gate=1.6, runs=3)
    assert s.probes[0] == (1.2, True) and len(s.probes) == 1


def test_a_failing_gate_is_flagged_and_a_passing_one_is_not():
    hw = 0.02
    near = margins.edge_from(margins.find_edge(passes_below(0.025), 0.0, 0.1, 1.5 * hw, 4), "above", hw, "x")
    far = margins.edge_from(margins.find_edge(passes_below(0.035), 0.0, 0.1, 1.5 * hw, 4), "above", hw, "x")
    assert near.flagged(0.0) and near.ratio(0.0) < 1.5 and "**" in margins.ratio_cell(near, 0.0)
    assert not far.flagged(0.0) and far.ratio(0.0) > 1.5 and "**" not in margins.ratio_cell(far, 0.0)


def test_half_widths_and_gates_from_the_box():
    assert margins.half_widths(1.0, (0.8, 1.4)) == (pytest.approx(0.2), pytest.approx(0.4))
    assert margins.half_widths(0.0, (0.0, 0.002)) == (0.0, 0.002)
    assert margins.half_widths(0.0, None) == (None, None)
    assert margins.half_widths(0.0, (0.15, 0.435)) == (0.0, 0.435)  # a box beside nominal: its far end
    assert margins.half_widths(0.00120125, (0.0012, 0.014))[0] == 0.0  # a rounding of nominal: no reach
    assert margins.gate_value(1.0, 0.2, "below") == pytest.approx(0.7)
    assert margins.gate_value(0.0, 0.0, "below") is None


# -- the table ------------------------------------------------------------------------------------

def test_the_table_shows_each_edge_its_checks_its_ratio_and_its_rerun():
    below = margins.Edge("below", -0.1, 0.03, -0.03, -0.04, ("drift < 5 cm",), "wheelleg run balance x", ())
    above = margins.Edge("above", 0.1, 0.03, 0.1, None, (), None, ((0.045, True), (0.1, True)))
    no_room = margins.Edge("below", 0.0, 0.0, 0.0, None, (), None, ())
    not_found = margins.Edge("above", 0.05, 0.002, 0.003, None, (), None, ((0.003, True),))
    keys = (margins.KeyMargins("com_x_m", "m", 0.0, (-0.03, 0.03), below, above),
            margins.KeyMargins("command_delay_s", "s", 0.0, (0.0, 0.002), no_room, not_found))
    lines = margins.render_markdown([margins.ScenarioMargins("balance", 3, True, "", "r", keys)], 3)
    assert lines[0] == "## Robustness margins" and "### balance (seed 3)" in lines
    assert ("| com_x_m | m | 0 | -0.03..0.03 | -0.04 (passes -0.03) | drift < 5 cm | **1.33** | "
            "beyond allowed range (passes 0.1) | - | >3.33 |") in lines
    assert ("| command_delay_s | s | 0 | 0..0.002 | - (allowed range ends at nominal) | - | - | "
            "not found (passes 0.003) | - | >1.50 |") in lines
    assert "1 of 3 edges under 1.5x the box's half-width." in lines
    assert "- com_x_m below, -0.04: drift < 5 cm" in lines and "      wheelleg run balance x" in lines
    assert margins.ratio_cell(below, 0.0) == "**1.33**"


def test_a_failing_nominal_is_said_with_its_rerun_and_no_table():
    lines = margins.render_markdown([margins.ScenarioMargins("jump", 0, False, "FALLEN", "wheelleg run jump", ())], 3)
    assert "The nominal plant fails (FALLEN): no margins. Rerun alone:" in lines
    assert "    wheelleg run jump" in lines and not any(line.startswith("| key") for line in lines)


# -- the search over keys and scenarios, on a fake rig ------------------------------------------

EDGES = {"com_x_m": (-0.02, 0.07), "command_delay_s": (None, 0.01)}  # fail at or past these (fake rig)
RUNS: list = []


def fake_run(job: sampling.Job, settings: execution.RunSettings) -> dict:
    """A stand-in for the rig: fails past EDGES (drift check) and, for "jump", always at nominal."""
    RUNS.append(job)
    row = execution.failed_row(job, None)
    bad = job.scenario == "jump"
    for key, value in job.overrides.items():
        low, high = EDGES.get(key, (None, None))
        bad |= (low is not None and value <= low) or (high is not None and value >= high)
    row["checks"] = [{"name": "drift < 5 cm", "passed": not bad, "figure": None, "detail": "max drift"},
                     {"name": "no controller deadline miss", "passed": True, "figure": 0, "detail": "0"}]
    row["passed"] = not bad
    row["wall_s"] = 0.0
    return execution.finish_files(row, job, settings)


def run_margins(argv: list[str]) -> int:
    args = cli.build_parser().parse_args(["margins", *argv])
    return margins_command.run(args, runner=fake_run, processes=False)


def test_the_command_finds_each_edge_writes_the_table_and_the_same_arguments_give_the_same_table(tmp_path, capsys):
    argv = ["balance", "--keys", "com_x_m=-0.03..0.03", "command_delay_s=0..0.004", "--runs-per-key", "10",
            "--workers", "2", "-q"]
    code = run_margins([*argv, "--out", str(tmp_path / "a")])
    printed = capsys.readouterr().out
    data = json.loads((tmp_path / "a" / "margins.json").read_text())
    keys = {k["key"]: k for k in data["scenarios"][0]["keys"]}
    com, delay = keys["com_x_m"], keys["command_delay_s"]
    assert com["below"]["passing"] > -0.02 >= com["below"]["failing"]
    assert com["above"]["passing"] < 0.07 <= com["above"]["failing"]
    assert com["box"] == [-0.03, 0.03]
    assert delay["below"]["probes"] == []  # the allowed range ends at nominal
    assert delay["above"]["ratio"] == pytest.approx(delay["above"]["failing"] / 0.004)
    assert com["below"]["failed_checks"] == ["drift < 5 cm"]
    flagged = {(k, side) for k, v in keys.items() for side in ("below", "above") if v[side]["flagged"]}
    assert flagged == {("com_x_m", "below")} and code == 1  # 0.02 m against a box half-width of 0.03

    table = (tmp_path / "a" / "margins.md").read_text()
    assert "| com_x_m | m | 0 | -0.03..0.03 |" in table and "**0." in table
    assert printed.startswith("# Robustness margins") and "| command_delay_s | s | 0 | 0..0.004 |" in printed
    rerun = shlex.split(com["above"]["rerun"])
    assert rerun[:5] == ["wheelleg", "run", "balance", "--seed", "0"]
    assert f"com_x_m={com['above']['failing']!r}" in rerun and com["above"]["rerun"] in table

    run_margins([*argv, "--out", str(tmp_path / "b")])
    other = (tmp_path / "b" / "margins.md").read_text().replace(str(tmp_path / "b"), str(tmp_path / "a"))
    assert other == table


def test_a_search_resumes_from_its_journal_and_more_runs_extend_the_fewer_runs_probes(tmp_path, capsys):
    argv = ["balance", "--keys", "com_x_m=-0.03..0.03", "command_delay_s=0..0.004", "--workers", "1", "-q"]
    RUNS.clear()
    run_margins([*argv, "--runs-per-key", "6", "--out", str(tmp_path / "fresh")])
    fresh = list(RUNS)
    RUNS.clear()
    run_margins([*argv, "--runs-per-key", "2", "--out", str(tmp_path / "grown")])
    first = list(RUNS)
    RUNS.clear()
    run_margins([*argv, "--runs-per-key", "6", "--out", str(tmp_path / "grown")])
    def ids(jobs):
        return sorted((j.sample, tuple(j.overrides.items())) for j in jobs)

    assert len(first) == 4 and not set(ids(first)) & set(ids(RUNS))  # nominal and 3 gates, not run again
    assert ids(first + RUNS) == ids(fresh)
    tables = [(tmp_path / d / "margins.md").read_text().replace(str(tmp_path / d), "DIR") for d in ("fresh", "grown")]
    assert tables[0].replace("--runs-per-key 6 --keys", "") == tables[1].replace("--runs-per-key 6 --keys", "")
    RUNS.clear()
    run_margins([*argv, "--runs-per-key", "6", "--duration", "2", "--out", str(tmp_path / "grown")])
    assert len(RUNS) == len(fresh)  # another duration: nothing of the journal is reused


def test_a_failing_nominal_stops_that_scenario_only(tmp_path, capsys):
    RUNS.clear()
    code = run_margins(["jump", "balance", "--keys", "com_x_m", "--workers", "1", "-q", "--out", str(tmp_path)])
    printed = capsys.readouterr().out
    assert code == 1
    assert [j.overrides for j in RUNS if j.scenario == "jump"] == [{}]  # its nominal run, nothing more
    assert "The nominal plant fails (max drift)" in printed and "wheelleg run jump --seed 0" in printed
    assert any(j.scenario == "balance" and j.overrides for j in RUNS)


def test_default_keys_are_the_presets_box():
    assert margin_runs.margin_boxes("tolerance", []) == sampling.campaign_ranges("tolerance", [])
    box = sampling.campaign_ranges("tolerance", [])
    assert margin_runs.margin_boxes("tolerance", ["hip_frictionloss", "com_z_m=-0.01..0.02"]) == {
        "hip_frictionloss": box.get("hip_frictionloss"), "com_z_m": (-0.01, 0.02)}
    beside = {key: span for key, span in box.items() if not span[0] <= OVERRIDES[key].default <= span[1]}
    assert margin_runs.margin_boxes("tolerance", list(beside)) == beside  # a preset's range may lie beside nominal


@pytest.mark.parametrize("argv, message", [
    (["nosuch"], "no scenario 'nosuch'"),
    (["balance", "--keys", "bogus"], "--keys bogus: unknown plant override"),
    (["balance", "--keys", "com_x_m=0.01..0.03"], "must contain the nominal 0"),
    (["balance", "--keys", "com_x_m=-1..0.03"], "impossible: allowed -0.1..0.1"),
    (["balance", "--keys", "com_x_m=a..b"], "--keys 'com_x_m=a..b': LOW and HIGH must be numbers"),
    (["balance", "--keys", "com_x_m", "com_x_m"], "named twice"),
    (["balance", "--preset", "nope"], "no preset 'nope'"),
    (["quadruped/quad-balance-stand", "--keys", "wheel_torque_lag_s"], "not modelled for the quadruped robot"),
    (["balance", "--runs-per-key", "1"], "need at least 2"),
])
def test_bad_input_is_a_one_line_error_exit_2(tmp_path, capsys, argv, message):
    RUNS.clear()
    assert run_margins([*argv, "--out", str(tmp_path / "m")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("margins: ") and message in err and err.count("\n") == 1
    assert RUNS == [] and not (tmp_path / "m" / "margins.md").exists()


# -- one real run ----------------------------------------------------------------------------

@pytest.mark.slow
def test_a_real_edge_large_command_delay_fails_balance_and_its_rerun_gives_the_same_failure(tmp_path):
    """Balance for 1.5 s with command latency: 3 runs above nominal (3 ms passes, 50 ms falls, then between)."""
    args = cli.build_parser().parse_args(["margins", "balance", "--keys", "command_delay_s=0..0.002",
                                          "--runs-per-key", "6", "--duration", "1.5", "--workers", "1", "-q",
                                          "--out", str(tmp_path)])
    spec = margins_command.margin_spec(args)
    settings = execution.RunSettings(tmp_path.resolve(), args.duration)
    [result] = margins_command.run_search(spec, settings, 1, True)
    edge = result.keys[0].above
    assert result.nominal_passed and OVERRIDES["command_delay_s"].default == 0.0
    assert edge.probes[0] == (0.003, True) and edge.probes[1] == (0.05, False)
    assert edge.passing < edge.failing <= 0.05 and edge.failed_checks
    argv = shlex.split(edge.rerun)
    assert cli.main([*argv[1:], "--no-plot"]) == 1  # the failing run, alone, fails again


# -- the campaign report gets the same table --------------------------------------------------

def test_campaign_margins_appends_the_same_table_to_the_report(tmp_path):
    from wheelleg.hil.commands import campaign

    argv = ["campaign", "balance", "--samples", "3", "--vary", "com_x_m=-0.03..0.03", "--margins",
            "--runs-per-key", "8", "--workers", "1", "-q", "--out", str(tmp_path)]
    campaign.run(cli.build_parser().parse_args(argv), runner=fake_run, processes=False)
    report = (tmp_path / "report.md").read_text()
    own = (tmp_path / "margins.md").read_text()
    rows = [line for line in own.splitlines() if line.startswith("| com_x_m |")]
    assert len(rows) == 1 and rows[0] in report and "## Robustness margins" in report
    assert "--margins --runs-per-key 8" in report
    data = json.loads((tmp_path / "margins.json").read_text())
    above = data["scenarios"][0]["keys"][0]["above"]
    assert above["passing"] < 0.07 <= above["failing"]
    assert str(tmp_path / "margins" / "runs" / "balance") in above["rerun"]  # apart from the sampled runs
    RUNS.clear()
    campaign.run(cli.build_parser().parse_args(argv), runner=fake_run, processes=False)
    assert RUNS == [] and (tmp_path / "report.md").read_text() == report  # resumed: journals, nothing run again


def test_campaign_margins_without_a_box_is_a_one_line_error(tmp_path, capsys):
    from wheelleg.hil.commands import campaign

    args = cli.build_parser().parse_args(["campaign", "balance", "--margins", "--out", str(tmp_path)])
    assert campaign.run(args, runner=fake_run, processes=False) == 2
    assert capsys.readouterr().out == "campaign: --margins needs a box: --preset or --vary\n"
