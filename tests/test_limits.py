"""tools/limits.py's search, with a fake scenario runner (no rig)."""
import pytest

from tools import limits
from tools.limits import search_limit


def threshold(limit):
    """A fake feat: passes up to ``limit``; records every size asked."""
    asked = []

    def passes(size):
        asked.append(size)
        return size <= limit

    return passes, asked


def test_walks_up_then_bisects_between_the_last_pass_and_the_first_failure():
    passes, asked = threshold(4.6)
    result = search_limit(passes, (2.0, 4.0, 6.0, 8.0), bisect_steps=2)
    assert asked == [2.0, 4.0, 6.0, 5.0, 4.5]  # 8 is never tried once 6 failed
    assert result.best == 4.5 and result.first_fail == 5.0
    assert result.tried == [(2.0, True), (4.0, True), (6.0, False), (5.0, False), (4.5, True)]


def test_every_rung_passing_reports_the_top_and_no_failure():
    passes, asked = threshold(100.0)
    result = search_limit(passes, (1.0, 2.0, 3.0))
    assert result.best == 3.0 and result.first_fail is None and asked == [1.0, 2.0, 3.0]


def test_first_rung_failing_reports_no_best():
    passes, asked = threshold(0.5)
    result = search_limit(passes, (1.0, 2.0))
    assert result.best is None and result.first_fail == 1.0 and asked == [1.0]


def test_bad_ladders_are_refused():
    for ladder in ((), (2.0, 1.0), (1.0, 1.0)):
        with pytest.raises(ValueError):
            search_limit(lambda s: True, ladder)


def test_table_rows_say_what_was_found():
    fig = limits.Figure("x", "thing", "m", lambda size: None, (1.0,), (1.0,), 0.2)
    row = limits._row(fig, limits.SearchResult(0.15, 0.2, [(0.1, True), (0.2, False), (0.15, True)]))
    assert "| thing | 0.15 m | 0.2 m |" in row and "0.2 x" in row
    assert ">=" in limits._row(fig, limits.SearchResult(0.3, None, [(0.3, True)]))


def test_every_figure_has_a_factory_that_makes_a_checked_scenario():
    figs = limits.figures()
    assert {f.name for f in figs} >= {"jump", "jump-step", "drop", "push", "slope", "speed", "step-down"}
    for f in figs:
        scenario = f.factory(f.coarse[0])
        assert scenario.checks, f.name


def test_only_refuses_an_unknown_figure(capsys):
    with pytest.raises(SystemExit):
        limits.main(["--only", "nope"])
