"""The repository stands alone: no pointers to documents it does not hold, no dead links.

Code, comments, DBC comments, scripts and the README must not send a reader to
notes on design, protocols or control, source documents or tracker issues kept
outside the repository; what they need is in ``docs/``. Every relative
link in README.md and docs/*.md must reach a file of the repository (and, with
an anchor, a heading of that file).
"""
from __future__ import annotations

import codecs
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

# Written so that this file does not match itself (no bare literal of any pointer).
OUTSIDE_POINTER = re.compile(
    r"DESIGN\.md"                      # the design notes
    r"|(?<!docs/)\bprotocols\.md"      # the protocol notes (docs/protocols.md is ours)
    r"|control[._ ]notes"              # the notes on control
    r"|[Ss]eed 00[0-9]"                # the source documents, by number
    r"|[Ii]ssue [0-9]+"                # tracker issues
    r"|shared[/]"                      # the folder that held them
)
# In docs/ a source document may be named as a source; the rest still may not appear.
DOCS_POINTER = re.compile(r"DESIGN\.md|control[._ ]notes|[Ii]ssue [0-9]+|shared[/]")

SKIP_DIRS = {".git", ".venv", "__pycache__", ".pytest_cache", ".hypothesis", "build", "dist", "out", "docs"}
SKIP_PATHS = {ROOT / "tests" / "traces"}  # recorded data, not prose


def _text_files(top: Path):
    for path in sorted(top.rglob("*")):
        rel_parts = path.relative_to(ROOT).parts
        if any(p in SKIP_DIRS or p.endswith(".egg-info") or p.startswith(".venv") for p in rel_parts[:-1]):
            continue
        if any(path.is_relative_to(skip) for skip in SKIP_PATHS) or not path.is_file():
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue  # binary
        if "\0" not in text:
            yield path, text


def pointers(text: str, pattern: re.Pattern = OUTSIDE_POINTER) -> list[tuple[int, str]]:
    """(line number, line) of every line of ``text`` that points outside the repository."""
    return [(n, line.strip()) for n, line in enumerate(text.splitlines(), 1) if pattern.search(line)]


def _report(found: dict) -> str:
    return "\n".join(f"{path}:{n}: {line}" for path, hits in found.items() for n, line in hits)


def test_no_code_comment_or_readme_points_outside_the_repository():
    found = {}
    for path, text in _text_files(ROOT):
        hits = pointers(text)
        if hits:
            found[path.relative_to(ROOT)] = hits
    assert not found, "pointers to documents outside the repository:\n" + _report(found)


def test_docs_point_at_nothing_outside_the_repository():
    found = {p.relative_to(ROOT): pointers(p.read_text(encoding="utf-8"), DOCS_POINTER) for p in DOCS.glob("*.md")}
    found = {p: hits for p, hits in found.items() if hits}
    assert not found, "pointers in docs/:\n" + _report(found)


# --- links --------------------------------------------------------------------------
FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"\[[^\]\n]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*#*\s*$", re.M)


def _prose(markdown: str) -> str:
    """The markdown without fenced code blocks and inline code (no links or headings there)."""
    return INLINE_CODE.sub("", FENCE.sub("", markdown))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[`*_]|\[([^\]]*)\]\([^)]*\)", lambda m: m.group(1) or "", heading).lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(markdown: str) -> set[str]:
    """Every heading anchor of a markdown text, with GitHub's -1, -2 suffixes for repeats."""
    seen: dict[str, int] = {}
    out = set()
    for heading in HEADING.findall(_prose(markdown)):
        base = slug(heading)
        count = seen.get(base, 0)
        out.add(base if count == 0 else f"{base}-{count}")
        seen[base] = count + 1
    return out


def broken_links(path: Path, markdown: str, root: Path = ROOT) -> list[str]:
    """Relative links of ``markdown`` (the text of ``path``) that reach no file or heading."""
    broken = []
    for target in LINK.findall(_prose(markdown)):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        if not file_part:  # an anchor in this document
            if anchor not in anchors(markdown):
                broken.append(f"{target}: no heading with that anchor in this document")
            continue
        dest = (path.parent / file_part).resolve()
        if not dest.is_relative_to(root) or not dest.exists():
            broken.append(f"{target}: no such file in the repository")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest.read_text(encoding="utf-8")):
            broken.append(f"{target}: no heading with that anchor in {dest.relative_to(root)}")
    return broken


DOCUMENTS = [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]


@pytest.mark.parametrize("path", DOCUMENTS, ids=[str(p.relative_to(ROOT)) for p in DOCUMENTS])
def test_every_relative_link_resolves(path):
    assert path.is_file()
    assert broken_links(path, path.read_text(encoding="utf-8")) == []


def test_the_docs_the_readme_promises_exist():
    for name in ("architecture", "design", "protocols", "robot", "control", "measurements"):
        assert (DOCS / f"{name}.md").is_file(), name


# --- the checks themselves can fail -------------------------------------------------------
def test_pointer_pattern_catches_each_kind_and_spares_the_docs():
    # The pointers are written rot13-encoded, so this file holds none of them itself.
    bad = [codecs.decode(line, "rot13") for line in (
        "frr QRFVTA.zq", "(../funerq/cebgbpbyf.zq §1)", "pbageby_abgrf §1.8",
        "frrq 000'f qrgrpg gnfx", "Vffhr 5: snhygf", "cebgbpbyf.zq §1.4")]
    for line in bad:
        assert pointers(line), line
    for line in ["docs/protocols.md §1.4", "seeded generator", "seed 0", "the issue's aims", "docs/design.md"]:
        assert not pointers(line), line


def test_link_check_reports_a_missing_file_and_a_missing_anchor(tmp_path):
    (tmp_path / "a.md").write_text("# Title\n\n## Some Section: here\n")
    doc = tmp_path / "b.md"
    text = ("[ok](a.md) [ok](a.md#some-section-here) [web](https://x.org/y) `[code](nowhere.md)`\n"
            "[gone](missing.md) [bad anchor](a.md#nope) [self](#local) [self](#elsewhere)\n\n## Local\n")
    assert broken_links(doc, text, root=tmp_path) == [
        "missing.md: no such file in the repository",
        "a.md#nope: no heading with that anchor in a.md",
        "#elsewhere: no heading with that anchor in this document",
    ]
