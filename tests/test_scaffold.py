"""``wheelleg new-robot``: the skeleton (hil/scaffold/), its names, its refusals, and tests/plugin_robot as its output."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from wheelleg.hil import cli, scaffold

PLUGIN = Path(__file__).resolve().parent / "plugin_robot"


def test_the_third_robot_is_the_skeleton_of_the_name_balancer():
    """tests/plugin_robot is what ``wheelleg new-robot balancer`` writes, file for file."""
    skeleton = scaffold.files("balancer")
    committed = {p.relative_to(PLUGIN) for p in PLUGIN.rglob("*")
                 if p.is_file() and "__pycache__" not in p.parts and ".egg-info" not in str(p)}
    assert set(skeleton) == committed
    assert [str(p) for p in skeleton if (PLUGIN / p).read_text() != skeleton[p]] == []


def test_the_skeletons_gains_are_its_design_scripts(balancer):
    """gains.py is what design.py computes from constants.py (computed, not typed)."""
    from wheelleg_balancer import design  # noqa: PLC0415

    k = design.lqr_gains()
    assert design.gains_text(k) == (PLUGIN / "wheelleg_balancer" / "gains.py").read_text()
    assert k[2] < 0 and design.delayed_loop_radius(k) < 1.0  # leaning forward drives forward; stable with a delay


def test_names_become_a_package_a_distribution_and_class_names():
    files = scaffold.files("my-robot")
    assert Path("wheelleg_my_robot/robot.py") in files
    robot = files[Path("wheelleg_my_robot/robot.py")]
    assert 'name="my-robot"' in robot and "MyRobotPhysics" in robot and "{{" not in "".join(files.values())
    assert 'my-robot = "wheelleg_my_robot.robot:ROBOT"' in files[Path("pyproject.toml")]
    assert 'name = "wheelleg-my-robot"' in files[Path("pyproject.toml")]


@pytest.mark.parametrize("bad", ["My-Robot", "my_robot", "9lives", "my--robot", "", "robot-"])
def test_a_name_that_is_no_robot_name_is_a_one_line_error(bad):
    with pytest.raises(ValueError, match="lower-case letters and digits"):
        scaffold.placeholders(bad)


def test_the_command_writes_a_new_package_and_refuses_a_folder_with_files(tmp_path, capsys):
    target = tmp_path / "pkg"
    assert cli.main(["new-robot", "my-robot", "--dir", str(target)]) == 0
    assert (target / "wheelleg_my_robot" / "scenarios.py").is_file()
    assert "pip install -e" in capsys.readouterr().out
    before = (target / "pyproject.toml").read_text()
    assert cli.main(["new-robot", "other", "--dir", str(target)]) == 2
    assert "is not an empty folder" in capsys.readouterr().err
    assert (target / "pyproject.toml").read_text() == before  # nothing overwritten
    assert cli.main(["new-robot", "quadruped", "--dir", str(tmp_path / "q")]) == 2
    assert "installed already" in capsys.readouterr().err and not (tmp_path / "q").exists()


@pytest.fixture
def balancer(monkeypatch):
    """tests/plugin_robot's modules importable (not installed here), forgotten afterwards."""
    monkeypatch.syspath_prepend(str(PLUGIN))
    for name in [m for m in sys.modules if m.startswith("wheelleg_balancer")]:
        monkeypatch.delitem(sys.modules, name)
    yield
    for name in [m for m in sys.modules if m.startswith("wheelleg_balancer")]:
        del sys.modules[name]


def test_the_skeletons_controller_never_raises_on_a_frame(balancer):
    """Random ids (its own and any), lengths, kinds and payloads on both buses, seeded; it ticks on."""
    import random  # noqa: PLC0415

    import can  # noqa: PLC0415

    from wheelleg.dbc import CAN1, CAN2  # noqa: PLC0415
    from wheelleg_balancer.controller import Balancer, Mode  # noqa: PLC0415

    rng = random.Random(29)
    own = [0x080, 0x100, 0x101, 0x102, 0x201, 0x202, 0x300]
    controller = Balancer()
    for tick in range(400):
        now = tick * controller.period_s
        for _ in range(8):
            frame_id = rng.choice(own) if rng.random() < 0.7 else rng.randrange(1 << 11)
            data = bytes(rng.randrange(256) for _ in range(rng.randrange(9)))
            msg = can.Message(arbitration_id=frame_id, data=data, is_extended_id=rng.random() < 0.1,
                              is_remote_frame=rng.random() < 0.05, check=False)
            controller.on_frame(msg, rng.choice((CAN1, CAN2)), now)
        result = controller.tick(tick, now)
        assert [m.arbitration_id for m in result.frames[CAN2]] == [0x710]  # the heartbeat, every tick
    assert controller.bad_frames > 0 and controller.mode in set(Mode)


def test_the_skeletons_program_imports_no_part_of_the_rig_but_dbc_and_controller():
    """As on the robot: ``python -m wheelleg_balancer`` needs no MuJoCo, emulators or hil."""
    code = ("import sys; import wheelleg_balancer.__main__; "
            "print(sorted({m.split('.')[0] if not m.startswith('wheelleg.') else '.'.join(m.split('.')[:2]) "
            "for m in sys.modules if m.startswith(('mujoco', 'wheelleg.emulators', 'wheelleg.hil'))}))")
    env = {**os.environ, "PYTHONPATH": str(PLUGIN)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
