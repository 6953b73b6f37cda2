"""A robot from outside the rig: tests/plugin_robot (the ``wheelleg-balancer`` package) installed by pip.

One throwaway virtualenv (tests/throwaway_venv.py: the rig's dependencies come
from the interpreter running the tests) gets the rig (the session's wheel of this
checkout, --no-deps, as a team installs it) and the balancer package, built and
installed into it by pip. Then, with that venv's ``wheelleg`` and nothing of the rig changed: the
robot is listed with its package, its two scenarios pass, their traces
replay identically, a small campaign runs, inspect and decode read its trace,
and the pytest plugin's ``rig_run`` runs its scenario; a skeleton of ``wheelleg new-robot``
installs, is listed and balances.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from sharing import BUILDS_THE_SOURCE_TREE
from throwaway_venv import make_venv, pip_install
from wheelleg.hil import robots

pytestmark = BUILDS_THE_SOURCE_TREE  # the venv fixture installs the session's wheel of this checkout

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "tests" / "plugin_robot"
RIG_FOLDERS = ("dbc", "controller", "emulators", "hil", "wheelleg")


def run(venv: Path, *args, timeout_s: float = 600, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """A command of the venv's ``bin/`` (its own interpreter and scripts, never this process's)."""
    command = [str(venv / "bin" / args[0]), *args[1:]]
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env.update(MUJOCO_GL="disable", VIRTUAL_ENV=str(venv), PATH=f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}")
    return subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout_s)


def ok(done: subprocess.CompletedProcess) -> str:
    assert done.returncode == 0, f"{done.args}: exit {done.returncode}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done.stdout


@pytest.fixture(scope="module")
def venv(tmp_path_factory, checkout_wheel) -> Path:
    """A venv with the rig (this checkout's wheel) and the balancer package installed by pip."""
    home = tmp_path_factory.mktemp("plugin-venv")
    venv = home / "venv"
    python = make_venv(venv)  # sees the rig's dependencies, not this interpreter's wheelleg
    source = home / "plugin_robot"  # built from a copy: pip builds a local folder in place
    shutil.copytree(PLUGIN, source, ignore=shutil.ignore_patterns("__pycache__", "build", "*.egg-info"))
    pip_install(python, "--no-deps", str(checkout_wheel))
    pip_install(python, "--no-deps", "--no-build-isolation", str(source))
    return venv


def test_no_file_of_the_rig_names_the_balancers_package():
    """What the balancer needs comes from its package: no module, DBC, model or pyproject line of the rig names
    it (the scaffold's template and help use the word as an example name only)."""
    named = [str(p.relative_to(ROOT)) for folder in RIG_FOLDERS for p in (ROOT / folder).rglob("*")
             if p.is_file() and p.suffix in (".py", ".dbc", ".xml", ".toml", ".tmpl")
             and ("wheelleg_balancer" in p.read_text() or "wheelleg-balancer" in p.read_text())]
    named += ["pyproject.toml"] if "balancer" in (ROOT / "pyproject.toml").read_text() else []
    assert named == []
    assert "balancer" not in robots.BUILTIN and "balancer" not in robots.names()  # not installed here


@pytest.mark.slow
def test_an_installed_robot_package_is_listed_runs_replays_and_campaigns(venv, tmp_path):
    listed = ok(run(venv, "wheelleg", "list", "--robot", "balancer", "-v"))
    assert listed.splitlines()[0].startswith("balancer (run as balancer/NAME or --robot balancer) from "
                                             "wheelleg-balancer 0.1.0: two-wheeled self-balancing robot")
    assert "  balance " in listed and "  offline-wheel " in listed
    heads = [line.split(" ")[0] for line in ok(run(venv, "wheelleg", "list")).splitlines() if not line[:1].isspace()]
    assert heads == ["wheel-legged", "balancer", "quadruped"]

    for scenario in ("balance", "offline-wheel"):
        out = ok(run(venv, "wheelleg", "run", f"balancer/{scenario}", "--out", str(tmp_path), "--no-plot", "-q"))
        assert f"balancer/{scenario}: PASSED" in out and "[FAIL]" not in out
        replay = run(venv, "wheelleg", "replay", str(tmp_path / f"{scenario}.mcap"))
        assert ": identical (" in ok(replay)
        assert "warning:" not in replay.stderr, replay.stderr  # the bug report: nothing lacking, nothing differing
    inspected = ok(run(venv, "wheelleg", "inspect", str(tmp_path / "offline-wheel.mcap")))
    assert "mode DISABLED, warning level 4, offline left_wheel" in inspected  # its own mode names and devices
    decoded = ok(run(venv, "wheelleg", "decode", str(tmp_path / "balance.mcap"), "--id", "0x201"))
    assert "C620_Feedback_1(" in decoded and "RotorSpeed" in decoded

    campaign = tmp_path / "campaign"
    ok(run(venv, "wheelleg", "campaign", "balancer/balance", "--samples", "2", "--vary", "body_mass_scale=0.9..1.2",
           "--duration", "2.5", "--workers", "1", "--out", str(campaign), "-q", timeout_s=1200))
    rows = [json.loads(line) for line in (campaign / "results.jsonl").read_text().splitlines()]
    assert [r["scenario"] for r in rows] == ["balancer/balance"] * 2
    assert all(r["error"] is None and r["passed"] for r in rows), rows


@pytest.mark.slow
def test_the_pytest_plugin_runs_the_installed_robots_scenario(venv, tmp_path):
    (tmp_path / "test_team.py").write_text(
        "def test_balancer_balances(rig_run):\n"
        "    run = rig_run('balancer/balance', duration=2.5)\n"
        "    run.assert_passed()\n"
        "    assert run.meta['robot'] == 'balancer' and abs(run.window('pitch', 2.0)).max() < 0.02\n")
    out = ok(run(venv, "python", "-m", "pytest", "-q", "-p", "no:cacheprovider", "-o", "addopts=",
                 "test_team.py", cwd=tmp_path))
    assert "1 passed" in out


@pytest.mark.slow
def test_a_new_robots_skeleton_installs_and_is_listed(venv, tmp_path):
    ok(run(venv, "wheelleg", "new-robot", "my-bot", "--dir", str(tmp_path / "my-bot")))
    pip_install(venv / "bin" / "python", "--no-deps", "--no-build-isolation", str(tmp_path / "my-bot"))
    listed = ok(run(venv, "wheelleg", "list", "--robot", "my-bot"))
    assert listed.startswith("my-bot (run as my-bot/NAME or --robot my-bot) from wheelleg-my-bot 0.1.0: ")
    out = ok(run(venv, "wheelleg", "run", "my-bot/balance", "--duration", "2.5", "--out", str(tmp_path / "out"),
                 "--no-plot", "-q"))
    assert "my-bot/balance: PASSED" in out
