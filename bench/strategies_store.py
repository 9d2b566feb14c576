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


def retrain(
    run_file: Path, store: Path, budget: int, seed: int, surrogate: dict[str, Any] | None = None
) -> dict[str, Any] | None:
    """Diagnostic: the pool a run had after ``budget`` oracle calls, trained from scratch
    (``warm_start`` off: every member up to ``max_epochs`` with early stopping, like model
    version 1), scored on the same validation suite. Separates what the strategy collected from
    what the campaign's chain of warm-started trainings made of it. ``surrogate``: another
    configuration to train on that pool (e.g. the other feature set; default: the run's)."""
    run = json.loads(run_file.read_text())
    row = run["budgets"].get(str(budget))
    if row is None:
        return None
    fresh_store(store)
    from alcove.db import open_transaction
    from alcove.models import Campaign, PoolVersion
    from alcove.pool.service import load_training_pool
    from alcove.science.ocp import task_preset
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate
    from alcove.surrogates.validation import _metrics, _suite_arrays

    t0, cpu0 = time.perf_counter(), cpu_seconds()
    with open_transaction() as s:
        c = s.query(Campaign).order_by(Campaign.id).first()  # the run's campaign: the first in its store
        pv = s.query(PoolVersion).filter_by(campaign_id=c.id, version=row["pool_version"]).one()
        pool = load_training_pool(s, pv)
        motions = _suite_arrays(s, c.validation_suite_id)
    chosen = run.get("surrogate", {}) if surrogate is None else surrogate
    config = SurrogateConfig.parse({**chosen, "warm_start": False})
    preset = task_preset(TASK).model.oracle_preset()
    result = train_surrogate(pool, config, 1000 + seed, preset=preset)
    m = _metrics(result.model, motions)
    return {
        "strategy": run["strategy"],
        "seed": run["seed"],
        "budget": budget,
        "oracle_calls": row["oracle_calls"],
        "campaign_force_rmse": row["force_rmse"],
        "features": config.features,
        "retrained_force_rmse": m["force_rmse"],
        "retrained_moment_rmse": m["moment_rmse"],
        "retrained_components": m["components"],
        "retrained_calibration": m["calibration"],
        "epochs": result.metrics.epochs,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": cpu_seconds() - cpu0,
    }


def iterations(campaign_id: int) -> list[dict[str, Any]]:
    from alcove.db import open_transaction
    from alcove.models import Iteration, IterationMetrics, ModelVersion, ValidationMetrics

    with open_transaction() as s:
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


def cumulative_calls(s: Any, campaign_id: int, upto: int) -> list[int]:
    """Cumulative oracle calls after iterations 0 .. upto (every attempt, also of failed iterations)."""
    from alcove.models import Iteration

    calls = {it.index: it.oracle_calls for it in s.query(Iteration).filter(Iteration.campaign_id == campaign_id)}
    out, total = [], 0
    for k in range(upto + 1):
        total += calls.get(k, 0)
        out.append(total)
    return out


def run_suite(campaign_id: int) -> int | None:
    """Replay the campaign's validation motions still queued (in this process); the suite id once complete."""
    from alcove.db import open_transaction
    from alcove.models import Campaign, SuiteStatus, ValidationMotion, ValidationSuite
    from alcove.oracles.validation import run_motion

    with open_transaction() as s:
        c = s.get(Campaign, campaign_id)
        sid = c.validation_suite_id if c is not None else None
        if sid is None:
            return None
        ids = [m.id for m in s.query(ValidationMotion).filter_by(suite_id=sid, status="queued")]
    for i in ids:
        run_motion(i, "bench")
    with open_transaction() as s:
        suite = s.get(ValidationSuite, sid)
        return sid if suite is not None and suite.status == SuiteStatus.complete.value else None


def score(campaign_id: int, suite_id: int, version: int) -> dict[str, Any]:
    """Model version ``version``'s suite figures (its stored row, else computed now)."""
    from alcove.db import open_transaction
    from alcove.models import ModelVersion, ValidationMetrics
    from alcove.surrogates.validation import compute_for_model

    with open_transaction() as s:
        mv = s.query(ModelVersion).filter_by(campaign_id=campaign_id, version=version).one()
        row = s.query(ValidationMetrics).filter_by(model_version_id=mv.id).one_or_none()
        if row is not None:
            return scored(
                {
                    "force_rmse": row.force_rmse,
                    "moment_rmse": row.moment_rmse,
                    "components": row.components,
                    "calibration": row.calibration,
                }
            )
        mv_id = mv.id
    m = compute_for_model(mv_id, suite_id)
    assert m is not None, "the validation suite is not complete"
    return scored(m)


def scored(m: dict[str, Any]) -> dict[str, Any]:
    """A budget's figures: force and moment RMSE, fx, fz, my overall and in contact, the calibration."""
    out = {"force_rmse": m["force_rmse"], "moment_rmse": m["moment_rmse"], "calibration": m.get("calibration")}
    components = m.get("components") or {}
    for c in ("fx", "fz", "my", "fx_contact", "fz_contact", "my_contact"):
        out[f"{c}_rmse"] = components.get(c)
    return out
