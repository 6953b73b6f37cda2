"""Robots found as installed plug-ins (the ``wheelleg.robots`` entry points), and broken ones.

Each test installs packages the way pip leaves them for importlib.metadata: a
``NAME-VERSION.dist-info`` folder (METADATA, entry_points.txt) beside the
package's modules, in a folder put on ``sys.path``. The installed robot is the
default one's description under another name (``stand_in``).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import pytest

from wheelleg.hil import robots, scenarios
from wheelleg.hil.commands import list as list_command

STAND_IN = """
import dataclasses
from wheelleg.hil import robots
ROBOT = dataclasses.replace(robots.get("wheel-legged"), name={name!r}, summary="a stand-in", scenario_modules=())
"""


def install(site: Path, package: str, version: str, points: dict[str, str], modules: dict[str, str]) -> None:
    """Write package ``package`` ``version`` into ``site``: its modules and its ``wheelleg.robots`` entry points."""
    for module, text in modules.items():
        (site / f"{module}.py").write_text(textwrap.dedent(text))
    info = site / f"{package.replace('-', '_')}-{version}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {package}\nVersion: {version}\n")
    lines = "".join(f"{name} = {value}\n" for name, value in points.items())
    (info / "entry_points.txt").write_text(f"[{robots.GROUP}]\n{lines}")


@pytest.fixture
def site(tmp_path, monkeypatch):
    """A folder on ``sys.path`` to install packages into; the registry looks again before and after."""
    monkeypatch.syspath_prepend(str(tmp_path))
    forget()
    yield tmp_path
    forget()


def forget() -> None:
    """The registry and the modules of the packages a test installs, forgotten: each test installs its own."""
    robots.reset()
    for module in ("acme_robot", "bad_robot", "gripper_robot"):
        sys.modules.pop(module, None)


def plugin_warnings(record) -> list[str]:
    return [str(w.message) for w in record if issubclass(w.category, robots.RobotPluginWarning)]


def test_an_installed_robot_is_listed_with_its_package_and_its_version(site, capsys):
    install(site, "acme-robots", "1.2.3", {"acme": "acme_robot:ROBOT"}, {"acme_robot": STAND_IN.format(name="acme")})
    assert robots.names() == ("wheel-legged", "acme", "quadruped")
    assert robots.get("acme").summary == "a stand-in"
    assert robots.origin("acme") == "acme-robots 1.2.3"
    assert robots.origin("wheel-legged").startswith("wheelleg-hil ")
    assert list_command.run(argparse.Namespace(verbose=False, robot=None)) == 0
    heads = [line for line in capsys.readouterr().out.splitlines() if not line.startswith("  ")]
    assert heads[1] == "acme (run as acme/NAME or --robot acme) from acme-robots 1.2.3: a stand-in; 0 scenarios"


BROKEN = {
    "import error": ({"bad": "bad_robot:ROBOT"}, {"bad_robot": "import no_such_module_anywhere\n"},
                     "robot plug-in 'bad' of package broken-pkg 0.1: cannot load bad_robot:ROBOT: "
                     "ModuleNotFoundError: No module named 'no_such_module_anywhere'"),
    "no such attribute": ({"bad": "bad_robot:ROBOT"}, {"bad_robot": "X = 1\n"},
                          "robot plug-in 'bad' of package broken-pkg 0.1: cannot load bad_robot:ROBOT: AttributeError"),
    "wrong object": ({"bad": "bad_robot:ROBOT"}, {"bad_robot": "ROBOT = {'name': 'bad'}\n"},
                     "robot plug-in 'bad' of package broken-pkg 0.1: bad_robot:ROBOT is a dict, not a "
                     "wheelleg.hil.robots.Robot"),
    "another robot's name": ({"bad": "bad_robot:ROBOT"}, {"bad_robot": STAND_IN.format(name="other")},
                             "robot plug-in 'bad' of package broken-pkg 0.1: bad_robot:ROBOT is the robot 'other'; "
                             "the entry point's name must be the robot's"),
    "a taken name": ({"quadruped": "bad_robot:ROBOT"}, {"bad_robot": STAND_IN.format(name="quadruped")},
                     "robot plug-in 'quadruped' of package broken-pkg 0.1 is ignored: the name is taken by "
                     "package wheelleg-hil "),
    "scenarios that do not import": ({"bad": "bad_robot:ROBOT"}, {"bad_robot": STAND_IN.format(name="bad").replace(
        "scenario_modules=()", "scenario_modules=('no_such_scenarios',)")},
        "robot plug-in 'bad' of package broken-pkg 0.1: its scenarios: ModuleNotFoundError: "
        "No module named 'no_such_scenarios'"),
}


@pytest.mark.parametrize("case", BROKEN)
def test_a_broken_plugin_is_one_warning_naming_its_package_and_the_rest_still_works(site, capsys, case):
    points, modules, message = BROKEN[case]
    install(site, "broken-pkg", "0.1", points, modules)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        assert list_command.run(argparse.Namespace(verbose=False, robot=None)) == 0
        tables = scenarios.by_robot()
    found = plugin_warnings(record)
    assert len(found) == 1 and found[0].startswith(message) and "\n" not in found[0]
    assert list(tables) == ["wheel-legged", "quadruped"]  # the rig's own robots, whole
    assert scenarios.get("quadruped/quad-push").robot == "quadruped"
    assert robots.get("quadruped").summary.startswith("12 CyberGear")  # a taken name keeps the rig's robot
    heads = [line.split(" ")[0] for line in capsys.readouterr().out.splitlines() if not line.startswith("  ")]
    assert heads == ["wheel-legged", "quadruped"]


def test_asking_for_a_broken_plugin_by_name_is_a_one_line_error(site):
    install(site, "broken-pkg", "0.1", {"bad": "bad_robot:ROBOT"}, {"bad_robot": "raise RuntimeError('boom')\n"})
    with pytest.warns(robots.RobotPluginWarning, match="package broken-pkg 0.1: .*RuntimeError: boom"):
        with pytest.raises(KeyError, match="package broken-pkg 0.1"):
            scenarios.get("bad/balance")
    with pytest.raises(KeyError, match="no robot 'nobody'"):
        robots.get("nobody")


def test_the_command_line_prints_a_broken_plugin_as_one_line_on_stderr(tmp_path):
    install(tmp_path, "broken-pkg", "0.1", {"bad": "bad_robot:ROBOT"}, {"bad_robot": "import no_such_module\n"})
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, "-m", "wheelleg.hil.cli", "list"], env=env, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stderr.splitlines() == [
        "wheelleg: warning: robot plug-in 'bad' of package broken-pkg 0.1: cannot load bad_robot:ROBOT: "
        "ModuleNotFoundError: No module named 'no_such_module'"]
    assert done.stdout.startswith("wheel-legged (the default) from wheelleg-hil ")


def test_the_rigs_own_robots_stay_known_without_their_entry_points(monkeypatch):
    """The fallback (``robots.BUILTIN``): metadata that lacks the group (a stale editable install)."""
    monkeypatch.setattr(robots.importlib.metadata, "entry_points", lambda group: ())
    robots.reset()
    try:
        assert robots.names() == ("wheel-legged", "quadruped")
        assert robots.get("quadruped").name == "quadruped"
    finally:
        robots.reset()


def test_the_rigs_entry_points_are_its_builtin_table():
    """pyproject.toml's ``wheelleg.robots`` group and ``robots.BUILTIN`` (its fallback, and the path ``get`` takes
    for the rig's own names without looking at the packages) name the same robots at the same objects."""
    import tomllib  # noqa: PLC0415

    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]
    assert project["entry-points"][robots.GROUP] == robots.BUILTIN


@pytest.mark.parametrize("name", sorted(robots.BUILTIN))
def test_a_trace_reader_gets_the_rigs_robots_bus_files_without_loading_them(name):
    assert robots.bus_files(name) == {bus.role: bus.dbc_files for bus in robots.get(name).buses}


OWN_DBC = """VERSION ""
NS_ :
BS_:
BU_: GRIPPER CONTROLLER
BO_ 1024 GripperState: 2 GRIPPER
 SG_ Opening : 0|16@1+ (0.001,0) [0|0.2] "m" CONTROLLER
"""

WITH_OWN_DBC = """
import dataclasses
from pathlib import Path
from wheelleg.hil import robots
base = robots.get("wheel-legged")
own = Path(__file__).resolve().parent / "gripper.dbc"
buses = (dataclasses.replace(base.buses[0], dbc_files=(*base.buses[0].dbc_files, own)), base.buses[1])
ROBOT = dataclasses.replace(base, name="gripper", buses=buses, scenario_modules=())
"""


def test_a_plugins_own_dbc_file_decodes_its_frames_and_travels_with_its_traces(site):
    """A bus may name a file of the plug-in's package (a path): its databases, a trace's decoding from its
    attachments, and the bug report's comparison take it like the rig's own files."""
    from wheelleg.hil.analyze.bug_report import installed_dbcs  # noqa: PLC0415
    from wheelleg.hil.record.derived import attached_dbs  # noqa: PLC0415

    (site / "gripper.dbc").write_text(OWN_DBC)
    install(site, "gripper-robot", "2.0", {"gripper": "gripper_robot:ROBOT"}, {"gripper_robot": WITH_OWN_DBC})
    robot = robots.get("gripper")
    assert robot.databases()["can1"].get_message_by_name("GripperState").decode(b"\x10\x27") == {"Opening": 10.0}
    assert site / "gripper.dbc" in robot.dbc_paths() and robots.bus_files("gripper")["can1"][-1] == site / "gripper.dbc"
    assert installed_dbcs("gripper")["gripper.dbc"] == site / "gripper.dbc"
    # a trace decodes with the file it carries, not with today's copy
    recorded = OWN_DBC.replace("(0.001,0)", "(0.002,0)").encode()
    dbs = attached_dbs({"gripper.dbc": recorded}, {"robot": "gripper", "can1": "vcan0", "can2": "vcan1"})
    assert dbs["vcan0"].get_message_by_name("GripperState").decode(b"\x10\x27") == {"Opening": 20.0}
    assert "GripperState" not in {m.name for m in dbs["vcan1"].messages}
