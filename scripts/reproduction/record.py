"""What a reproduction run records: the comparison rows, texts, timings and named facts."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
TASK = "head-headrest-2phase"
RELEVANT = (("fx", 0, "N"), ("fz", 2, "N"), ("my", 4, "N m"))  # the non-zero components of the planar model

# What the paper reports (Fahse et al.), quoted in the comparison table.
PAPER = {
    "angle": "within about ±0.15 rad of the start",
    "torque": "within a few N m",
    "torque_phase2": "zero (rest without actuation)",
    "first_contact": "0.29 s (its example motion)",
    "peak_force": "of order 100-300 N",
    "peak_moment": "of order 10-30 N m",
    "force_rmse": "3.32 N (iteration 200)",
    "moment_rmse": "0.265 N m (iteration 200)",
    "trend": "decreasing, with spikes",
    "fe_time": "about 3 min per FE run (LS-DYNA, laptop)",
    "relative_rmse": "about 1-3 % (3.32 N of 100-300 N; 0.265 N m of 10-30 N m)",
    "peak_ratio": "below 1 (underestimates high forces)",
}


@dataclass
class Row:
    """One line of the comparison table: the alcove value is always a number with a unit."""

    section: str
    quantity: str
    paper: str
    value: float
    unit: str
    note: str = ""

    def cell(self) -> str:
        return f"{fmt(self.value)} {self.unit}".strip()


@dataclass
class Report:
    quick: bool
    out: Path
    rows: list[Row] = field(default_factory=list)
    sections: dict[str, list[str]] = field(default_factory=dict)
    errors: dict[str, str] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    facts: dict[str, float] = field(default_factory=dict)  # named values for the verdict
    timings_note: str = ""

    def add(self, section: str, quantity: str, paper: str, value: float, unit: str, note: str = "") -> None:
        self.rows.append(Row(section, quantity, paper, float(value), unit, note))

    def text(self, section: str, *lines: str) -> None:
        self.sections.setdefault(section, []).extend(lines)

    def figure_path(self, name: str) -> Path:
        return self.out / "reproduction" / name

    def to_json(self) -> dict[str, Any]:
        """Everything the page is rendered from (saved as ``reproduction/run.json`` beside it)."""
        return {
            "quick": self.quick,
            "rows": [vars(r) for r in self.rows],
            "sections": self.sections,
            "errors": self.errors,
            "timings": self.timings,
            "facts": self.facts,
            "timings_note": self.timings_note,
        }

    @classmethod
    def from_json(cls, data: dict[str, Any], out: Path) -> Report:
        rep = cls(quick=bool(data["quick"]), out=out)
        rep.rows = [Row(**r) for r in data["rows"]]
        rep.sections, rep.errors = dict(data["sections"]), dict(data["errors"])
        rep.timings, rep.facts = dict(data["timings"]), dict(data["facts"])
        rep.timings_note = data.get("timings_note", "")
        return rep


def fmt(x: float) -> str:
    if x is None or not math.isfinite(x):
        return "nan"
    if x == 0:
        return "0"
    if abs(x) >= 1000 or abs(x) < 1e-3:
        return f"{x:.3e}"
    return f"{x:.4g}"


def phase_bounds(task: Any) -> list[tuple[str, float, float]]:
    out, t = [], 0.0
    for i, ph in enumerate(task.phases):
        out.append((getattr(ph, "name", None) or f"phase {i + 1}", t, t + ph.duration))
        t += ph.duration
    return out
