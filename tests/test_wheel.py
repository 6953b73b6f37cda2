"""The built wheel, tried as a robot team would: one import name, and the pytest
plugin working in a project that has its own ``controller`` and ``hil`` packages."""
from __future__ import annotations

import subprocess
import textwrap
import zipfile

import pytest

from sharing import BUILDS_THE_SOURCE_TREE
from throwaway_venv import REPO, make_venv, pip_install

pytestmark = pytest.mark.slow  # a wheel build and a venv: scheduled first (tests/conftest.py)


@BUILDS_THE_SOURCE_TREE  # the session's wheel (tests/conftest.py)
def test_the_wheel_has_one_top_level_package(checkout_wheel):
    with zipfile.ZipFile(checkout_wheel) as zf:
        names = zf.namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith((".dist-info", ".data"))}
    assert tops == {"wheelleg"}
    # the data the package reads at run time travels with it
    assert {"wheelleg/dbc/cybergear.dbc", "wheelleg/emulators/robot/robot.xml", "wheelleg/hil/bus/uml/uml-vcan.sh",
            "wheelleg/hil/bus/uml/uml-vcan-init.sh", "wheelleg/hil/bus/uml/uml_xstate_shim.c",
            "wheelleg/hil/scaffold/template/pyproject.toml.tmpl",
            "wheelleg/hil/scaffold/template/package/robot.xml.tmpl"} <= set(names)
    # the firmware's sources, so an installed wheel builds it (wheelleg.hil.firmware_build)
    firmware = {"wheelleg/firmware/" + str(path.relative_to(REPO / "firmware"))
                for pattern in ("Makefile", "**/*.c", "**/*.h") for path in (REPO / "firmware").glob(pattern)
                if "build" not in path.relative_to(REPO / "firmware").parts}
    assert len(firmware) > 30 and firmware <= set(names), sorted(firmware - set(names))
    with zipfile.ZipFile(checkout_wheel) as zf:  # its robots, registered as any robot package registers its own
        points = zf.read(next(n for n in names if n.endswith(".dist-info/entry_points.txt"))).decode()
    assert "[wheelleg.robots]\nquadruped = wheelleg.hil.robots.quadruped:ROBOT\n" in points


@BUILDS_THE_SOURCE_TREE  # the session's wheel (tests/conftest.py)
def test_a_project_with_its_own_controller_and_hil_uses_rig_run(checkout_wheel, tmp_path):
    """The collision the editable install hid: a team's own ``controller``/``hil`` packages."""
    # the dependencies come from this interpreter's site-packages; the package only from the wheel
    py = make_venv(tmp_path / "venv")
    pip_install(py, "--no-deps", "--force-reinstall", str(checkout_wheel))
    project = tmp_path / "team"
    for package in ("controller", "hil"):
        (project / package).mkdir(parents=True)
        (project / package / "__init__.py").write_text("TEAM = True\n")
        (project / package / "params.py").write_text("GAIN = 1.0\n")
    (project / "pytest.ini").write_text("[pytest]\npythonpath = .\n")
    (project / "tests").mkdir()
    (project / "tests" / "test_team.py").write_text(textwrap.dedent("""
        import controller, hil
        import wheelleg

        def test_our_packages_and_the_rig(rig_run):
            assert controller.TEAM and hil.TEAM
            assert "site-packages" in wheelleg.__file__
            run = rig_run("balance", duration=1.5, seed=1)
            run.assert_passed()
            assert abs(run.window("pitch", 1.0)).max() < 0.035  # rad, 2 deg
    """))
    # -I: the repository (this test's cwd, PYTHONPATH) must not leak into the team's session
    done = subprocess.run([str(py), "-I", "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests"],
                          cwd=project, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "1 passed" in done.stdout
