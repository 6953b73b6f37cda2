"""Build the robot's C firmware (``firmware/``, docs/firmware.md) with the machine's C compiler.

``build('lib')`` makes the in-process lockstep library ``libwheelleg_fw.so`` (the ABI of
``firmware/include/wl_lockstep.h``), ``build('linux')`` the SocketCAN process
``wheelleg-fw``, ``build('test')`` runs the C unit tests; each returns the built path.
The sources come from the installed package (``wheelleg.firmware``: in a clone, the
top-level ``firmware/``), so an installed wheel builds them too. The build goes to
``firmware/build/`` when that folder is writable, else to a per-user cache, or to
``out_dir``. ``make`` keeps it incremental: a second call costs a make that finds it
up to date; concurrent calls for one directory take turns (a lock file in it).

    python -m wheelleg.hil.firmware_build [lib|linux|test] [--out DIR]
"""
from __future__ import annotations

import argparse
import fcntl
import hashlib
import os
import shutil
import subprocess
import sys
from importlib import resources
from pathlib import Path

KINDS = {"lib": "libwheelleg_fw.so", "linux": "wheelleg-fw", "test": "fw-tests"}


class FirmwareBuildError(RuntimeError):
    """The firmware could not be built; the message is one line saying why."""


def source_dir() -> Path:
    """The firmware's sources: the package ``wheelleg.firmware`` (the clone's ``firmware/``)."""
    return Path(str(resources.files("wheelleg.firmware")))


def _default_out(src: Path) -> Path:
    if os.access(src, os.W_OK):
        return src / "build"
    tag = hashlib.sha256(str(src).encode()).hexdigest()[:12]
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "wheelleg" / "firmware" / tag


def build(kind: str = "lib", out_dir: str | Path | None = None) -> Path:
    """Build ``kind`` ('lib', 'linux' or 'test': the last also runs the C tests) into
    ``out_dir`` (default: ``firmware/build/`` or a per-user cache); returns the built file.

    Raises FirmwareBuildError (one line) when there is no C compiler or make, or the build fails.
    """
    if kind not in KINDS:
        raise FirmwareBuildError(f"unknown firmware build {kind!r}: one of {', '.join(KINDS)}")
    cc = os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        raise FirmwareBuildError(f"no C compiler: {cc!r} not found (install gcc, or set CC)")
    make = shutil.which("make")
    if make is None:
        raise FirmwareBuildError("no make: install make to build the firmware")
    src = source_dir()
    out = Path(out_dir) if out_dir is not None else _default_out(src)
    out.mkdir(parents=True, exist_ok=True)
    # one make at a time per build directory: pytest-xdist workers (or campaign workers) that all
    # ask for the library at once would otherwise write the same files together
    with open(out / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        proc = subprocess.run([make, "-s", "-C", str(src), f"BUILD={out.resolve()}", f"CC={cc}", kind],
                              capture_output=True, text=True)
    if proc.returncode != 0:
        lines = [line for line in (proc.stderr or proc.stdout).splitlines() if line.strip()]
        errors = [line for line in lines if "error" in line.lower()]  # a compiler's warnings come first
        detail = (errors or lines or [f"make exited {proc.returncode}"])[0]
        raise FirmwareBuildError(f"firmware {kind} build failed: {detail}")
    return out.resolve() / KINDS[kind]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m wheelleg.hil.firmware_build", description=__doc__.split("\n")[0])
    parser.add_argument("kind", nargs="?", default="lib", choices=tuple(KINDS))
    parser.add_argument("--out", help="build directory (default firmware/build/ or a per-user cache)")
    args = parser.parse_args(argv)
    try:
        path = build(args.kind, args.out)
    except FirmwareBuildError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
