"""DIR/results.jsonl, the campaign's journal, and DIR/campaign.json, what the campaign is.

A row is appended (and flushed) the moment its run is judged, so an
interrupted campaign loses at most the runs that were in flight: the same
command run again skips every (scenario, sample) already judged in the journal
(and runs again those that could not run: a dead worker, a rig error). At
the end the journal is rewritten in plan order, so the same command gives the
same file, wall times aside.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

RESULTS = "results.jsonl"
SPEC = "campaign.json"


class CampaignMismatch(ValueError):
    """DIR holds a different campaign (other scenarios, seed, ranges or duration)."""


def check_spec(out_dir: Path, spec: dict) -> None:
    """Write DIR/campaign.json, or check that the one there is ``spec`` (so resuming adds like to like)."""
    path = out_dir / SPEC
    if path.exists():
        before = json.loads(path.read_text())
        if before != spec:
            changed = sorted(k for k in spec.keys() | before.keys() if before.get(k) != spec.get(k))
            raise CampaignMismatch(f"{out_dir} holds another campaign (its {', '.join(changed)} differ); "
                                   "use another --out or the same arguments")
        return
    out_dir.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(spec, indent=1, sort_keys=True) + "\n")


class Journal:
    """The rows of DIR/results.jsonl by (scenario, sample); ``append`` adds one durably."""

    def __init__(self, out_dir: Path):
        self.path = out_dir / RESULTS
        self.rows: dict[tuple[str, int], dict] = {}
        if self.path.exists():
            self._load()

    def _load(self) -> None:
        text = self.path.read_text()
        if text and not text.endswith("\n"):  # killed in the middle of a row: drop the torn row
            text = text[: text.rfind("\n") + 1]
            self.path.write_text(text)
        for line in text.splitlines():
            if line.strip():
                row = json.loads(line)
                self.rows[(row["scenario"], row["sample"])] = row

    def finished(self, key: tuple[str, int]) -> bool:
        """(scenario, sample) ran to a verdict; a row with an ``error`` (the run could not run) did not."""
        return key in self.rows and not self.rows[key].get("error")

    def append(self, row: dict) -> None:
        self.rows[(row["scenario"], row["sample"])] = row
        with self.path.open("a") as f:
            f.write(json.dumps(row, sort_keys=True) + "\n")
            f.flush()
            os.fsync(f.fileno())

    def ordered(self, scenarios: list[str]) -> list[dict]:
        """The rows of ``scenarios`` by scenario (in that order), then sample."""
        rank = {name: i for i, name in enumerate(scenarios)}
        rows = [r for r in self.rows.values() if r["scenario"] in rank]
        return sorted(rows, key=lambda r: (rank[r["scenario"]], r["sample"]))

    def rewrite(self, scenarios: list[str]) -> None:
        """Rewrite the file in plan order (atomically: a crash leaves the old or the new file)."""
        tmp = self.path.with_suffix(".jsonl.tmp")
        tmp.write_text("".join(json.dumps(r, sort_keys=True) + "\n" for r in self.ordered(scenarios)))
        os.replace(tmp, self.path)
