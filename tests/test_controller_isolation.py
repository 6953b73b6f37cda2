"""The controller is deployed alone on the robot: it must not pull in the rig."""
import ast
import subprocess
import sys
from pathlib import Path

CONTROLLER = Path(__file__).resolve().parent.parent / "controller"
FORBIDDEN = ("mujoco", "emulators", "hil")


def _imported_roots(path: Path) -> set[str]:
    roots = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            roots.add(node.module.split(".")[0])
    return roots


def test_no_controller_module_imports_the_rig():
    offenders = {str(p.relative_to(CONTROLLER)): sorted(_imported_roots(p) & set(FORBIDDEN))
                 for p in CONTROLLER.rglob("*.py") if p.parent.name != "design"}
    offenders = {k: v for k, v in offenders.items() if v}
    assert offenders == {}


def test_running_controller_loads_no_rig_module():
    code = ("import sys, controller.node, controller.__main__; "
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in %r); print(bad)" % (FORBIDDEN,))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=CONTROLLER.parent)
    assert out.stdout.strip() == "[]"


def test_the_checker_sees_a_forbidden_import(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import numpy\nfrom emulators.physics import Physics\n")
    assert _imported_roots(bad) & set(FORBIDDEN) == {"emulators"}
