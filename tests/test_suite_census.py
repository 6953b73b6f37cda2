"""tools.suite_census: the suite's CPU by file and test, and the rig runs made more than once."""
from __future__ import annotations

import json

from tools import suite_census

RUN = {"scenario": "wheel-legged/drive", "seed": 0, "sim_s": 11.0, "plant": {}, "program": "python",
       "realtime": False, "cpu_s": 7.0}


def _row(test: str, cpu_s: float, children_s: float = 0.0, runs=()) -> dict:
    return {"test": test, "worker": "gw0", "wall_s": cpu_s, "cpu_s": cpu_s, "children_cpu_s": children_s,
            "runs": list(runs)}


def test_the_summary_sums_by_file_and_names_each_run_made_twice(tmp_path):
    rows = [_row("tests/test_a.py::test_one", 8.0, runs=[RUN]), _row("tests/test_a.py::test_two", 1.0, 2.0),
            _row("tests/test_b.py::test_drive", 9.0, runs=[RUN]),
            _row("tests/test_b.py::test_other_seed", 3.0, runs=[{**RUN, "seed": 1}])]
    (tmp_path / "gw0.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    lines = suite_census.summary(suite_census.load(tmp_path))
    assert lines[0] == "4 tests, 23.0 CPU s (2.0 in processes they started), 3 rig runs in the workers " \
                       "(21.0 CPU s, 33.0 simulated s)"
    assert "     12.0  tests/test_b.py" in lines and "     11.0  tests/test_a.py" in lines
    twice = lines[lines.index("rig runs made more than once: 1") + 1:]
    assert twice[0].startswith("  2x wheel-legged/drive seed 0 11.0 s")
    assert [line.split()[1] for line in twice[1:]] == ["tests/test_a.py::test_one", "tests/test_b.py::test_drive"]


def test_an_empty_folder_is_a_one_line_error(tmp_path, capsys):
    assert suite_census.main([str(tmp_path)]) == 1
    assert capsys.readouterr().err == f"error: no census rows in {tmp_path}\n"
