"""Developer tools, run from the repository root (``python -m tools.NAME``): not installed."""
import argparse


def known_scenario(text: str) -> str:
    """An argparse ``type`` for a scenario name ('NAME' or 'ROBOT/NAME'): a name the rig does not
    know is a one-line usage error (exit 2) listing the known ones, not a traceback."""
    from wheelleg.hil import scenarios  # noqa: PLC0415 (the rig only when a tool names a scenario)

    try:
        scenarios.get(text)
    except KeyError as exc:
        raise argparse.ArgumentTypeError(exc.args[0]) from None
    return text
