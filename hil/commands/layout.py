"""``wheelleg layout``: the path of the Foxglove layout that ships with the package (for ``run --live`` and traces)."""
from __future__ import annotations

import argparse

NAME = "layout"
HELP = ("print the path of the Foxglove layout for the rig's runs (3D view of /scene, key plots, events): "
        "import it in the Foxglove app (Layouts, Import from file)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    pass


def run(args: argparse.Namespace) -> int:
    from wheelleg.hil.watch.layout import LAYOUT_PATH

    print(LAYOUT_PATH)
    return 0
