"""The docs and the code speak of the software as it is, and point only at files the repository
ships.

- No development history in the docs, the code or the models: no mention of a work session or an
  issue number (the pattern below); superseded figures and their story belong in CHANGELOG.md.
- Every repository path named in backticks in README.md and docs/*.md exists.

Pure file reading: no import of the package, no simulation.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# What `grep -rniE "session [0-9]|sessions? [0-9]|issue #?[0-9]"` finds.
HISTORY = re.compile(r"sessions? [0-9]|issue #?[0-9]", re.IGNORECASE)
HISTORY_FOLDERS = ("docs", "tt_drake", "systems", "diagrams", "models", "tests")
HISTORY_SUFFIXES = (".md", ".py", ".yaml")

# A repository path: one of the shipped folders, then path characters. A code span such as
# `systems/wam.py: add_servo_hold` or `tests/x.py::test_y` names the file before the colon.
PATH = re.compile(r"(?<![\w./-])((?:docs|models|tests|tt_drake|systems|diagrams)/[\w./*<>-]*)")
CODE_SPAN = re.compile(r"`([^`]+)`")
FENCE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)
GYM_ID = re.compile(r"^tt_drake/\w+-v\d+$")  # a Gymnasium environment id, not a path


def _history_hits() -> list[str]:
    hits = []
    for folder in HISTORY_FOLDERS:
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix not in HISTORY_SUFFIXES or not path.is_file():
                continue
            if any(part in (".venv", "__pycache__") for part in path.parts):
                continue
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if HISTORY.search(line):
                    hits.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:100]}")
    return hits


def test_no_session_or_issue_numbers_in_docs_code_or_models():
    hits = _history_hits()
    assert not hits, ("development history (a session or issue number) in:\n"
                      + "\n".join(hits))


def _documents() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _named_paths(text: str) -> set[str]:
    """The repository paths named in backticks: inline code spans (which may wrap a line) and
    fenced code blocks."""
    spans = [m.group(0) for m in FENCE.finditer(text)]
    # An inline span wrapped over two lines (`tests/systems/\n  test_x.py`) names one path.
    spans += [re.sub(r"/\s*\n\s*", "/", m.group(1))
              for m in CODE_SPAN.finditer(FENCE.sub("", text))]
    names = set()
    for span in spans:
        for m in PATH.finditer(span):
            names.add(m.group(1).rstrip(".,;:"))
    return names


def _ignored(name: str) -> bool:
    """Placeholders and a run's outputs, not files of the repository."""
    return (any(mark in name for mark in ("DIR", "<", "*", "out/", "..."))
            or GYM_ID.match(name) is not None)


# The installed package's folders (`tt_drake/models/` of an installed tt-drake) and the
# repository's (setup.py maps them).
PACKAGE_FOLDERS = {"tt_drake/models/": "models/", "tt_drake/systems/": "systems/",
                   "tt_drake/diagrams/": "diagrams/"}


def _exists(name: str) -> bool:
    for installed, folder in PACKAGE_FOLDERS.items():
        if name.startswith(installed):
            name = folder + name[len(installed):]
    path = ROOT / name
    if path.exists():
        return True
    # An output prefix (`--out docs/img/curve` writes curve.png and curve.json) names files
    # that exist with an extension.
    return any(path.parent.glob(path.name + ".*")) if path.parent.is_dir() else False


def test_every_path_named_in_the_docs_exists():
    missing = []
    for document in _documents():
        for name in sorted(_named_paths(document.read_text(encoding="utf-8"))):
            if not _ignored(name) and not _exists(name):
                missing.append(f"{document.relative_to(ROOT)}: {name}")
    assert not missing, "paths named in the docs that the repository does not ship:\n" + \
        "\n".join(missing)


def test_the_checks_see_what_they_look_for():
    """The patterns themselves: a history mention, a wrapped span, a test id, placeholders."""
    number = "12"  # kept apart so that this file does not hold what it looks for
    assert HISTORY.search("measured in Session " + number)
    assert HISTORY.search("issue #" + number) and HISTORY.search("Issue " + number)
    assert HISTORY.search("sessions " + number) and not HISTORY.search("a session's deadline")
    text = ("Run `tests/systems/\n  test_wam.py` and `tests/x/test_y.py::test_z`; see\n"
            "```\npython docs/examples/a.py --out out/r.json\n```\n"
            "`DIR/artefacts/crkr.npz`, `tt_drake/ReturnBall-v0`, `systems/wam.py: add_servo_hold`.")
    names = _named_paths(text)
    assert {"tests/systems/test_wam.py", "tests/x/test_y.py", "docs/examples/a.py",
            "systems/wam.py", "tt_drake/ReturnBall-v0"} <= names
    assert "out/r.json" not in names  # not under a shipped folder
    assert _ignored("tt_drake/ReturnBall-v0") and _ignored("docs/faults/<fault>.yaml")
    assert _exists("tt_drake/diagrams/bench.py") and _exists("docs/img/gym_learning_curve")
    assert not _exists("docs/no_such_page.md")
    fenced = "```\n# the shipped models/learned/\ntt-drake serve\n```\n"
    assert _named_paths(fenced) == {"models/learned/"}
