"""The controller is deployed alone on the robot: it must not pull in the rig.

And the plant is the robot's truth, the controller's constants its belief: no
emulator takes a number from the controller (a shared wrong value would cancel out).
"""
import ast
import subprocess
import sys
from pathlib import Path

CONTROLLER = Path(__file__).resolve().parent.parent / "controller"
EMULATORS = CONTROLLER.parent / "emulators"
FORBIDDEN = ("mujoco", "wheelleg.emulators", "wheelleg.hil")


def _imported_modules(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
            names |= {f"{node.module}.{alias.name}" for alias in node.names}
    return names


def _forbidden(names, forbidden=FORBIDDEN) -> set[str]:
    return {f for f in forbidden for name in names if name == f or name.startswith(f + ".")}


def test_no_controller_module_imports_the_rig():
    files = [p for p in CONTROLLER.rglob("*.py") if p.parent.name != "design"]
    assert any(p.parent.name == "quadruped" for p in files)  # the quadruped's program is scanned too
    offenders = {str(p.relative_to(CONTROLLER)): sorted(_forbidden(_imported_modules(p))) for p in files}
    offenders = {k: v for k, v in offenders.items() if v}
    assert offenders == {}


def test_running_controller_loads_no_rig_module():
    code = ("import sys, wheelleg.controller.node, wheelleg.controller.__main__, "
            "wheelleg.controller.quadruped.node, wheelleg.controller.quadruped.__main__; "
            "bad = sorted(m for m in sys.modules if any(m == f or m.startswith(f + '.') for f in %r)); "
            "print(bad)" % (FORBIDDEN,))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=CONTROLLER.parent)
    assert out.stdout.strip() == "[]"


def test_the_checker_sees_a_forbidden_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import numpy\nfrom wheelleg.emulators.physics import Physics\n")
    assert _forbidden(_imported_modules(bad)) == {"wheelleg.emulators"}


def test_no_emulator_module_imports_the_controller():
    files = sorted(EMULATORS.rglob("*.py"))
    assert len(files) > 10  # the scan sees the emulators
    offenders = {str(p.relative_to(EMULATORS)): sorted(_forbidden(_imported_modules(p), ("wheelleg.controller",)))
                 for p in files}
    assert {k: v for k, v in offenders.items() if v} == {}


def test_the_plant_loads_no_controller_module():
    code = ("import sys, wheelleg.emulators.plant; "
            "print(sorted(m for m in sys.modules if m.startswith('wheelleg.controller')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=CONTROLLER.parent)
    assert out.stdout.strip() == "[]"
