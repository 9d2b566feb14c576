"""``scripts/check_history_refs.py`` (run by ``make lint``): code names no issue and no date.
It finds a planted issue number and date in a file of its own, leaves colours and plain
numbers alone, and the real source folders have none."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path
from types import ModuleType

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "scripts" / "check_history_refs.py"

# Assembled here so that this file does not carry what it plants.
ISSUE, HASH, MONTH = "iss" + "ue", "#", "Dec" + "ember"


def checker() -> ModuleType:
    spec = importlib.util.spec_from_file_location("check_history_refs", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run(*paths: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, paths)], capture_output=True, text=True, check=False)


def test_a_planted_issue_number_and_date_are_found(tmp_path: Path) -> None:
    planted = tmp_path / "planted.py"
    planted.write_text(
        f'"""Pauses a campaign ({ISSUE} 17 made it so)."""\n'
        f"x = 1  # see {HASH}31\n"
        f"# the default before 3 {MONTH} 2026\n"
        "# measured on 2026-12-03\n"
    )
    result = run(planted)
    assert result.returncode == 1, result.stdout
    found = result.stdout.splitlines()
    assert [line.split(": ", 1)[0].rsplit(":", 1)[1] for line in found] == ["1", "2", "3", "4"], found
    assert sum("issue number" in line for line in found) == 2
    assert sum(": date" in line for line in found) == 2


def test_colours_numbers_and_words_pass(tmp_path: Path) -> None:
    clean = tmp_path / "clean.tsx"
    clean.write_text(
        'const C = { a: "#000", b: "#1d2330", c: "#333333" };\n'
        "// 17 issues of a journal; step 2 of 3; version 2026.1; the 3rd of 5 motions\n"
        "const id = `item-${n}`; // an issue with the data, not a number\n"
    )
    result = run(clean)
    assert result.returncode == 0, result.stdout


def test_the_source_folders_name_no_issue_and_no_date() -> None:
    module = checker()
    found = module.check([REPO / root for root in module.ROOTS])
    assert not found, "say the constraint, not the history:\n" + "\n".join(found)


def test_make_lint_runs_the_checker() -> None:
    makefile = (REPO / "Makefile").read_text()
    lint = makefile.split("\nlint:", 1)[1].split("\n\n", 1)[0]
    assert "scripts/check_history_refs.py" in lint
