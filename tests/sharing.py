"""Tests that share one costly thing (a scenario run, a module's fixture) run on one xdist worker.

``rig_run`` caches a run per worker process (hil/pytest_plugin.py) and a
module-scoped fixture is built once per worker, so tests that share them save
the work only when they land on the same worker. With ``--dist loadgroup``
(pyproject's addopts) the tests of one ``xdist_group`` run on one worker:

- ``same_run(NAME)`` marks a test that calls ``rig_run(NAME)`` with the same
  arguments (seed, duration, plant) as another test; ``each_run(NAMES)`` gives
  ``parametrize`` values, each in its run's group;
- ``same_fixture(NAME)`` marks the tests that use one costly module fixture (or a module's
  cache that lives as long as the process);
- ``session_dir`` is a folder every xdist worker of this session sees, for a thing built
  once a session and used on any worker (the firmware library: a build that finds it
  made waits for the builder's lock and reuses it);
- ``BUILDS_THE_SOURCE_TREE`` marks the tests that build or install this checkout with pip
  (a wheel, an editable install in a venv): setuptools writes ``build/`` and the egg-info
  inside the tree, so two such builds at once on two workers break each other.

A missing mark costs time, never a result: the run or fixture is made twice.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest


def same_run(scenario: str) -> pytest.MarkDecorator:
    """The mark of the tests that judge ``rig_run(scenario)`` (same seed, duration, plant)."""
    return pytest.mark.xdist_group(f"run {scenario}")


def each_run(scenarios) -> list:
    """``parametrize`` values: each scenario name in the group of its run."""
    return [pytest.param(name, marks=same_run(name)) for name in scenarios]


def same_fixture(name: str) -> pytest.MarkDecorator:
    """The mark of the tests that use the module-scoped fixture ``name`` (built once per worker)."""
    return pytest.mark.xdist_group(f"fixture {name}")


BUILDS_THE_SOURCE_TREE = pytest.mark.xdist_group("builds the source tree")


def session_dir(tmp_path_factory: pytest.TempPathFactory, name: str) -> Path:
    """``name`` in this session's temporary folder, the same on every xdist worker (each worker's
    ``getbasetemp()`` is ``popen-gwN`` inside the session's)."""
    base = tmp_path_factory.getbasetemp()
    folder = (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / name
    folder.mkdir(exist_ok=True)
    return folder
