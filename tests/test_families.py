"""The ``wheelleg.devices`` entry-point group: the rig's families register there, a broken plug-in is one warning."""
from __future__ import annotations

import importlib.metadata
import logging

import pytest

from wheelleg.dbc import dbc_path
from wheelleg.emulators import family as F
from wheelleg.hil.cli import main

BUILTIN = {"cybergear", "c620", "c610", "gm6020", "damiao", "robstride", "imu"}


def test_the_rigs_families_come_from_the_entry_point_group():
    found = F.families()
    assert BUILTIN <= set(found)
    for name, fam in found.items():
        assert fam.name == name and fam.summary
        for dbc in fam.dbc_files:
            assert dbc_path(dbc).is_file()


class _Dist:
    name = "broken-motors"


class _Entry:
    """An entry point as importlib.metadata gives it, whose ``load`` we choose."""

    def __init__(self, name, value, loaded):
        self.name, self.value, self.dist, self._loaded = name, value, _Dist(), loaded

    def load(self):
        if isinstance(self._loaded, Exception):
            raise self._loaded
        return self._loaded


def test_a_broken_plugin_is_one_warning_naming_its_package_and_the_rest_loads(monkeypatch, caplog):
    real = importlib.metadata.entry_points(group=F.GROUP)
    fakes = [_Entry("nomotor", "nomotor:FAMILY", ImportError("No module named 'nomotor'")),
             _Entry("notafamily", "x:Y", object()),
             _Entry("cybergear", "x:CYBER", F.family("c620"))]  # entry name and family name differ
    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group: [*real, *fakes])
    with caplog.at_level(logging.WARNING, logger=F.__name__):
        found = F.families()
    assert BUILTIN <= set(found) and "nomotor" not in found
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 3 and all("broken-motors" in line and "\n" not in line for line in lines)
    assert "ImportError" in lines[0] and "not a DeviceFamily" in lines[1]


def test_a_plugin_family_is_served_by_wheelleg_emulate(monkeypatch):
    made = []

    def make(args, ids):
        made.append((args.flavour, list(ids)))
        raise ValueError("the test family makes nothing")

    def arguments(parser):
        parser.add_argument("--flavour", default="plain")

    plug = F.DeviceFamily("toymotor", "a toy", (), (3,), make, arguments)
    real = importlib.metadata.entry_points(group=F.GROUP)
    monkeypatch.setattr(importlib.metadata, "entry_points",
                        lambda group: [*real, _Entry("toymotor", "toy:FAMILY", plug)])
    assert main(["emulate", "toymotor", "--flavour", "sour", "-i", "virtual", "-c", "x"]) == 2
    assert made == [("sour", [3])]


def test_unknown_family_is_a_clear_error():
    with pytest.raises(ValueError, match="no device family 'nosuch'; installed: .*cybergear"):
        F.family("nosuch")


@pytest.mark.parametrize("argv, message", [
    (["robstride", "--id", "1", "--id", "2", "--uid", "5"], "--uid names one motor"),
    (["damiao", "--id", "0"], "ESC_ID must be 1..0x7FE"),
    (["damiao", "--id", "0x7FF"], "ESC_ID must be 1..0x7FE"),
    (["gm6020", "--id", "8"], "gm6020 id must be 1..7"),
    (["c610", "--id", "3", "--id", "3"], "--id given twice"),
])
def test_bad_family_options_are_one_line_errors(argv, message, capsys):
    assert main(["emulate", *argv, "-i", "virtual", "-c", "x"]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_each_family_makes_its_default_devices():
    from wheelleg.hil.cli import build_parser
    from wheelleg.hil.commands import emulate
    for name in BUILTIN:
        args = build_parser().parse_args(["emulate", name, "-i", "virtual", "-c", "x"])
        devices = emulate.make_devices(args)
        assert len(devices) == 1 and devices[0].internal_errors == 0
