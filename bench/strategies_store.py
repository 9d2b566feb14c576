"""Reading a ``python -m bench.strategies`` campaign's store: its iterations (oracle calls,
candidates, scores, picks, in-loop and validation errors) for the result file, and the
``--retrain STRATEGY SEED BUDGET`` diagnostic (a run's pool retrained from scratch)."""

from __future__ import annotations

import json
import os
import resource
import time
from pathlib import Path
from typing import Any

TASK = "head-headrest-scenarios"


def cpu_seconds() -> float:
    """CPU time of this process so far [s] (user + system)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def fresh_store(data_dir: Path) -> None:
    """Point alcove at a new embedded store in ``data_dir`` (SQLite, no broker) and migrate it."""
    data_dir.mkdir(parents=True, exist_ok=True)
    os.environ["ALCOVE_DATA_DIR"] = str(data_dir)
    os.environ["ALCOVE_DATABASE_URL"] = ""
    os.environ["ALCOVE_BROKER_URL"] = ""
    from alcove.db import migrate
    from alcove.settings import get_settings

    get_settings.cache_clear()
    migrate.upgrade()


def retrain(run_file: Path, store: Path, budget: int, seed: int) -> dict[str, Any] | None:
    """Diagnostic: the pool a run had after ``budget`` oracle calls, trained from scratch
    (``warm_start`` off: every member up to ``max_epochs`` with early stopping, like model
    version 1), scored on the same validation suite. Separates what the strategy collected from
    what the campaign's chain of warm-started trainings made of it."""
    run = json.loads(run_file.read_text())
    row = run["budgets"].get(str(budget))
    if row is None:
        return None
    fresh_store(store)
    from alcove.db import session_scope
    from alcove.models import Campaign, PoolVersion
    from alcove.pool.service import load_training_pool
    from alcove.science.ocp import task_preset
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate
    from alcove.surrogates.validation import _metrics, _suite_arrays

    t0, cpu0 = time.perf_counter(), cpu_seconds()
    with session_scope() as s:
        c = s.query(Campaign).order_by(Campaign.id).first()  # the run's campaign: the first in its store
        pv = s.query(PoolVersion).filter_by(campaign_id=c.id, version=row["pool_version"]).one()
        pool = load_training_pool(s, pv)
        motions = _suite_arrays(s, c.validation_suite_id)
    config = SurrogateConfig.parse({**run.get("surrogate", {}), "warm_start": False})
    preset = task_preset(TASK).model.oracle_preset()
    result = train_surrogate(pool, config, 1000 + seed, preset=preset)
    m = _metrics(result.model, motions)
    return {
        "strategy": run["strategy"],
        "seed": run["seed"],
        "budget": budget,
        "oracle_calls": row["oracle_calls"],
        "campaign_force_rmse": row["force_rmse"],
        "retrained_force_rmse": m["force_rmse"],
        "retrained_moment_rmse": m["moment_rmse"],
        "epochs": result.metrics.epochs,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": cpu_seconds() - cpu0,
    }


def iterations(campaign_id: int) -> list[dict[str, Any]]:
    from alcove.db import session_scope
    from alcove.models import Iteration, IterationMetrics, ModelVersion, ValidationMetrics

    with session_scope() as s:
        val = {
            mv.version: (vm.force_rmse, vm.moment_rmse)
            for mv, vm in s.query(ModelVersion, ValidationMetrics)
            .join(ValidationMetrics, ValidationMetrics.model_version_id == ModelVersion.id)
            .filter(ModelVersion.campaign_id == campaign_id)
        }
        loop = {
            m.iteration_index: (m.force_rmse, m.moment_rmse)
            for m in s.query(IterationMetrics).filter(IterationMetrics.campaign_id == campaign_id)
        }
        rows = []
        for it in s.query(Iteration).filter(Iteration.campaign_id == campaign_id).order_by(Iteration.index):
            rows.append(
                {
                    "k": it.index,
                    "status": it.status,
                    "oracle_calls": it.oracle_calls,
                    "scenario": (it.scenario or {}).get("values"),
                    "in_loop_rmse": loop.get(it.index),
                    "validation_of_model_k": val.get(it.index),
                    "candidates": [
                        {
                            "slot": c.slot,
                            "values": (c.scenario or {}).get("values"),
                            "converged": c.converged,
                            "score": c.score,
                            "pick": c.pick,
                            "force_rmse": c.force_rmse,
                        }
                        for c in it.candidates
                    ],
                }
            )
    return rows
