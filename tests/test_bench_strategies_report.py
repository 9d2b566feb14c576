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
