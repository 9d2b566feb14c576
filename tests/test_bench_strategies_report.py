"""bench.strategies' report: merging an earlier results JSON with a re-run of one strategy."""

from __future__ import annotations

import pytest

from bench.strategies_report import EARLIER, merge, summary

META = {
    "oracle": "fe-headrest-2d",
    "task": "t",
    "budgets": [8, 16],
    "batch": 4,
    "candidates": 16,
    "preliminary_seed": 0,
    "validation_seed": 0,
}


def _run(strategy: str, seed: int, f8: float, f16: float) -> dict:
    return {
        "strategy": strategy,
        "seed": seed,
        "budgets": {
            "8": {"oracle_calls": 8, "force_rmse": f8, "moment_rmse": 1.0},
            "16": {"oracle_calls": 16, "force_rmse": f16, "moment_rmse": 1.0},
        },
    }


def test_a_rerun_strategy_replaces_its_earlier_runs_in_the_goals_and_keeps_them_beside():
    earlier = {
        **META,
        "strategies": ["random-scenarios", "ensemble-disagreement"],
        "runs": [_run("random-scenarios", 0, 40.0, 30.0), _run("ensemble-disagreement", 0, 50.0, 45.0)],
    }
    new = {**META, "strategies": ["ensemble-disagreement"], "runs": [_run("ensemble-disagreement", 0, 35.0, 20.0)]}
    merged = merge(new, earlier)
    assert merged["strategies"] == ["random-scenarios", "ensemble-disagreement", "ensemble-disagreement" + EARLIER]
    s = summary(merged)
    assert s["table"]["ensemble-disagreement"][16]["force_mean"] == 20.0  # the new run
    assert s["table"]["ensemble-disagreement" + EARLIER][16]["force_mean"] == 45.0
    assert s["table"]["random-scenarios"][16]["force_mean"] == 30.0  # taken from the earlier file
    assert s["goals"]["beats_random_every_budget"] is True  # 35 < 40, 20 < 30: the new runs decide
    assert s["goals"]["reach_random_16"]["calls_needed"] == 16


def test_merging_runs_of_another_setup_is_refused_naming_the_field():
    earlier = {**META, "budgets": [8, 16, 32], "strategies": [], "runs": []}
    with pytest.raises(ValueError, match="budgets differs"):
        merge({**META, "strategies": [], "runs": []}, earlier)


def test_the_targets_compare_each_strategy_with_the_best_possible_line_by_median():
    def run(strategy: str, seed: int, rows: dict[int, tuple[float, float, float]]) -> dict:
        budgets = {
            str(b): {"oracle_calls": b, "force_rmse": f, "moment_rmse": 1.0, "fx_rmse": fx, "calibration": c}
            for b, (f, fx, c) in rows.items()
        }
        return {"strategy": strategy, "seed": seed, "budgets": budgets}

    meta = {**META, "budgets": [8, 16, 32]}
    runs = [
        # the line: fx 1.0 at 16 and 32 calls, force 6 at 32 (medians of 3 seeds)
        *(run("best-possible", s, {16: (7.0, 1.0, 0.7), 32: (6.0, 1.0, 0.75)}) for s in range(3)),
        # within 1.3x at 32 (1.2) and 1.5x at 16 (1.4); force 7.0 at 32 (1.17x); reaches 6 at 16 calls
        run("press-family", 0, {8: (9.0, 2.0, 0.9), 16: (6.0, 1.4, 0.85), 32: (7.0, 1.2, 0.82)}),
        # fx 2x at 32: misses; calibration 0.5
        run("paper", 0, {8: (30.0, 9.0, 0.3), 16: (20.0, 3.0, 0.4), 32: (15.0, 2.0, 0.5)}),
    ]
    t = summary({**meta, "strategies": ["best-possible", "press-family", "paper"], "runs": runs})["goals"]["targets"]
    assert t["fx_within_1.3x_at_32"]["ratios"] == {"press-family": pytest.approx(1.2), "paper": pytest.approx(2.0)}
    assert t["fx_within_1.3x_at_32"]["met"] is False and t["fx_within_1.5x_at_16"]["met"] is False
    assert t["best_force_within_1.2x_at_32"]["ratios"]["press-family"] == pytest.approx(7.0 / 6.0)
    assert t["best_force_within_1.2x_at_32"]["met"] is True
    assert t["reach_reference_32_in_16"]["calls_needed"] == {"press-family": 16, "paper": None}
    assert t["reach_reference_32_in_16"]["met"] is True
    assert t["calibration_0.8_at_32"]["medians"] == {"press-family": 0.82, "paper": 0.5}
    assert t["calibration_0.8_at_32"]["met"] is False
