"""A throwaway virtualenv that sees this interpreter's installed packages, as a team's would.

``python -m venv --system-site-packages`` is not that when the tests run inside a venv
(the README's way on most Linux systems): the new venv's "system" packages are the
*base* interpreter's, which lack the project's dependencies. So the new venv gets no
system site-packages and a ``.pth`` file naming every site-packages directory this
interpreter imports from instead. Only the directories are added, not their ``.pth``
files, so an editable install of the rig in them stays invisible: a wheel installed
into the throwaway venv is the only ``wheelleg`` there.

``build_wheel`` builds this checkout's wheel; ``tests/conftest.py``'s ``checkout_wheel``
does it once a session for every test that installs the rig into such a venv.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def site_dirs() -> list[str]:
    """This interpreter's site-packages directories, in import order."""
    return [p for p in sys.path if Path(p).name in ("site-packages", "dist-packages") and Path(p).is_dir()]


def make_venv(path: Path) -> Path:
    """A venv at ``path`` (no pip of its own) importing this interpreter's packages; its python."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(path)], check=True)
    python = path / "bin" / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                             check=True, capture_output=True, text=True).stdout.strip()
    (Path(purelib) / "_outer_site_packages.pth").write_text("\n".join(site_dirs()) + "\n")
    return python


def pip_install(python: Path, *args: str) -> subprocess.CompletedProcess:
    """This interpreter's pip installing into the venv of ``python`` (quiet; fails the test with pip's words)."""
    done = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q",
                           "--disable-pip-version-check", *args], capture_output=True, text=True)
    assert done.returncode == 0, f"pip install {' '.join(args)}: exit {done.returncode}\n{done.stderr[-4000:]}"
    return done


def build_wheel(out: Path) -> Path:
    """This checkout's wheel, built into ``out`` from a copy of the checkout; its path.

    From a copy: setuptools builds a local folder in place (build/, the egg-info, the
    compiled extension), and an editable install of this checkout leaves state there that
    broke an in-place build in CI.
    """
    source = out / "source"
    shutil.copytree(REPO, source, ignore=shutil.ignore_patterns(".git", ".venv", "build", "out", "*.egg-info",
                                                                 "__pycache__", "*.so", ".hypothesis", ".pytest_cache"))
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                           "-w", str(out), str(source)], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-4000:]
    (path,) = out.glob("wheelleg_hil-*.whl")
    return path
