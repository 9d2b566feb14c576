"""``scripts/reproduce.py --quick`` writes the reproduction page with all parts, figures and a
comparison table whose alcove column holds numbers (a smoke run of the whole pipeline:
OCP, FE replay, campaigns through the campaign service, remedies)."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SECTIONS = (
    "## 1. The multibody solution",
    "## 2. FE replay",
    "## 3. The active-learning loop",
    "## 4. Remedies against the baseline",
    "## Comparison with the paper",
    "## What this run shows",
    "## Where our model differs from the paper's",
)
FIGURES = ("multibody.png", "fe_replay.png", "campaign_rmse.png", "campaign_last.png", "remedies.png")


def _table(markdown: str) -> list[list[str]]:
    """Rows of the comparison table, cells split on unescaped pipes."""
    body = markdown.split("## Comparison with the paper", 1)[1].split("\n## ", 1)[0]
    rows = [ln for ln in body.splitlines() if ln.startswith("| ") and not ln.startswith("| part ")]
    return [[c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", ln)[1:-1]] for ln in rows]


@pytest.mark.slow
def test_quick_reproduction_writes_page_figures_and_numeric_table(tmp_path: Path) -> None:
    out = tmp_path / "docs"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ALCOVE_")}
    proc = subprocess.run(
        [
            sys.executable,
            str(REPO / "scripts" / "reproduce.py"),
            "--quick",
            "--out",
            str(out),
            "--data-dir",
            str(tmp_path / "data"),
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]

    md = (out / "reproduction.md").read_text()
    for heading in SECTIONS:
        assert heading in md, heading
    assert "This part failed" not in md
    for png in FIGURES:
        data = (out / "reproduction" / png).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n", png
        assert f"](reproduction/{png})" in md, png

    rows = _table(md)
    assert {r[0] for r in rows} == {"multibody", "fe", "campaign", "remedies"}
    values: dict[str, float] = {}
    for _section, quantity, _paper, cell, _note in rows:
        number = float(cell.split()[0])
        assert math.isfinite(number), (quantity, cell)
        values[quantity] = number
    # a few laws the numbers must obey, whatever the run
    assert values["max |torque|, phase 2"] < values["max |torque|, phase 1"]
    first_contact = next(v for q, v in values.items() if q.startswith("first contact"))
    assert 0.0 <= first_contact <= 1.0
    assert all(
        v > 0
        for q, v in values.items()
        if q.startswith(("force RMSE", "moment RMSE", "mean force RMSE", "mean moment RMSE"))
    )
    assert -1.0 <= values["Spearman rank correlation of force RMSE with k"] <= 1.0


@pytest.fixture
def reproduction(monkeypatch: pytest.MonkeyPatch):
    """The package behind scripts/reproduce.py, imported as the script imports it."""
    import importlib

    monkeypatch.syspath_prepend(str(REPO / "scripts"))
    return importlib.import_module("reproduction")


def test_remedy_iterations_fit_the_remaining_budget(reproduction) -> None:
    """The default number of remedy iterations: the largest m whose estimate (two campaigns like
    the baseline's first m iterations, one like its last ones) fits the time left; more time,
    more iterations; never more than the baseline's, never fewer than the floor."""
    from reproduction import campaigns as mod

    walls = {k: 3.0 + 0.02 * k for k in range(1, 201)}  # iterations get slower as the pool grows
    base = mod.CampaignRun(
        1,
        "baseline",
        "completed",
        "max_iterations",
        None,
        sum(walls.values()) + 1.0,
        [],
        None,
        breakdown={"iteration_wall": walls},
    )
    late = 3.0 + 0.02 * 191  # the median of the last 20

    def cost(m: int) -> float:
        return 2 * 1.0 + 2 * sum(walls[k] for k in range(1, m + 1)) + m * late + 60.0

    chosen = [mod.remedy_budget(base, 200, budget) for budget in (0.0, 600.0, 1200.0, 2400.0, 1e6)]
    assert chosen[0] == 10 and chosen[-1] == 200
    assert chosen == sorted(chosen)
    for budget, m in zip((600.0, 1200.0, 2400.0), chosen[1:4], strict=False):
        assert cost(m) <= budget < cost(m + 1)
    assert mod.remedy_budget(base, 5, 0.0) == 5


def test_without_matplotlib_the_script_names_the_extra_and_runs_nothing(
    reproduction, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """matplotlib is the ``reproduce`` extra, not a dependency: without it the script stops at once
    with one message that says how to install it (no traceback, no half-written page)."""
    from reproduction.cli import app
    from typer.testing import CliRunner

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ImportError
    out = tmp_path / "docs"
    result = CliRunner().invoke(app, ["--quick", "--out", str(out), "--data-dir", str(tmp_path / "data")])
    assert result.exit_code == 1, result.output
    assert "matplotlib" in result.output and "pip install -e '.[reproduce]'" in result.output
    assert isinstance(result.exception, SystemExit) and "Traceback" not in result.output  # a deliberate exit
    assert not out.exists() and not (tmp_path / "data").exists()
