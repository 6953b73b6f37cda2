"""``wheelleg new-robot``'s skeleton: a robot package for the rig, rendered from ``template/``.

The skeleton is a working robot: a two-wheeled balancer (two C620/M3508 wheel
drives, IMU and remote on CAN1) with its MJCF, plant, discrete-LQR controller
(gains from its own design script), ``balance`` and ``offline-wheel``
scenarios, README and pyproject.toml registering it under ``wheelleg.robots``.
A team edits its numbers into its own robot (docs/your-robot.md). Rendering
replaces ``{{name}}`` (the robot's name), ``{{Name}}`` (its CamelCase, for
class names), ``{{package}}`` (the import name, ``wheelleg_NAME``) and
``{{dist}}`` (the distribution, ``wheelleg-NAME``); a ``package/`` folder of
the template becomes the import package. tests/plugin_robot is this skeleton
for the name ``balancer``.
"""
from __future__ import annotations

import re
from pathlib import Path

TEMPLATE_DIR = Path(__file__).resolve().parent / "template"
NAME_PATTERN = re.compile(r"[a-z][a-z0-9]*(-[a-z0-9]+)*\Z")


def placeholders(robot: str) -> dict[str, str]:
    """The template's placeholders for the robot ``robot``; ValueError (one line) for a name that is not
    lower-case words of letters and digits joined by '-' (a robot's name, a Python package's once '_')."""
    if not NAME_PATTERN.match(robot):
        raise ValueError(f"robot name {robot!r}: lower-case letters and digits, words joined by '-', "
                         "starting with a letter (e.g. 'balancer', 'my-robot')")
    return {"name": robot, "Name": "".join(word.capitalize() for word in robot.split("-")),
            "package": f"wheelleg_{robot.replace('-', '_')}", "dist": f"wheelleg-{robot}"}


def files(robot: str) -> dict[Path, str]:
    """Relative path -> text of every file of ``robot``'s skeleton."""
    values = placeholders(robot)
    out = {}
    for template in sorted(TEMPLATE_DIR.rglob("*.tmpl")):
        parts = [values["package"] if part == "package" else part
                 for part in template.relative_to(TEMPLATE_DIR).with_suffix("").parts]
        text = template.read_text()
        for key, value in values.items():
            text = text.replace("{{" + key + "}}", value)
        out[Path(*parts)] = text
    return out


def write(robot: str, directory: Path) -> list[Path]:
    """Write ``robot``'s skeleton into ``directory`` (created; it must be empty or absent); the paths written.
    ValueError (one line) for a bad name or a directory that holds files."""
    skeleton = files(robot)
    if directory.exists() and (not directory.is_dir() or any(directory.iterdir())):
        raise ValueError(f"{directory} exists and is not an empty folder: the skeleton writes a new package")
    written = []
    for relative, text in skeleton.items():
        path = directory / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        written.append(path)
    return written
