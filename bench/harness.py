"""Benchmark harness: figures are registered by modules in ``bench/figures/``.

A figure is a function that runs one repetition and returns the measured value (in the
figure's unit). ``setup`` runs once per figure (untimed) and its return value is passed
to every repetition. Baselines: a figure may name another figure as its baseline; the
table then shows the ratio of the medians.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

FIGURES: list[Figure] = []
#: "quick" or "full", set by bench.run before the figures run (a figure may trim its setup in quick mode)
MODE = "full"


def quick() -> bool:
    return MODE == "quick"


@dataclass
class Figure:
    name: str
    unit: str
    run: Callable[[Any], float]
    target: float | None = None  # upper bound ("<= target") unless higher_is_better
    higher_is_better: bool = False
    reps: int = 5
    quick_reps: int = 3
    setup: Callable[[], Any] | None = None
    quick: bool = True  # included in --quick
    baseline: str | None = None
    group: str = ""
    notes: str = ""
    requires: Callable[[], str | None] | None = None  # returns a reason to skip, or None
    values: list[float] = field(default_factory=list)


def figure(name: str, unit: str, **kw: Any) -> Callable[[Callable[[Any], float]], Callable[[Any], float]]:
    """Decorator registering a figure."""

    def deco(fn: Callable[[Any], float]) -> Callable[[Any], float]:
        FIGURES.append(Figure(name=name, unit=unit, run=fn, **kw))
        return fn

    return deco


def timed(fn: Callable[[], Any]) -> float:
    """Wall time of ``fn()`` in seconds."""
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def summarize(fig: Figure) -> dict[str, Any]:
    v = fig.values
    med = statistics.median(v) if v else None
    within = None
    if med is not None and fig.target is not None:
        within = med >= fig.target if fig.higher_is_better else med <= fig.target
    return {
        "figure": fig.name,
        "group": fig.group,
        "unit": fig.unit,
        "median": med,
        "min": min(v) if v else None,
        "max": max(v) if v else None,
        "repetitions": len(v),
        "target": fig.target,
        "target_kind": ">=" if fig.higher_is_better else "<=",
        "within_target": within,
        "baseline": fig.baseline,
        "notes": fig.notes,
    }
