"""A finished campaign's worth of rows, synthesized through the services and repositories
(no OCP, no oracle, no worker): iterations with steps, metrics with curves, pool versions,
optionally a trained model version. Used by the route tests of several domains, by
``tests/e2e`` and by ``bench/figures/``."""

from __future__ import annotations

from datetime import timedelta

import numpy as np
from sqlalchemy.orm import Session

from alcove.campaigns import service as campaigns
from alcove.campaigns.config import StoppingRules
from alcove.campaigns.presets import oracle_version_for, surrogate_config_version_for, task_version_from_preset
from alcove.campaigns.schemas import CampaignCreate
from alcove.db.arrays import put_arrays
from alcove.models import Campaign, Iteration, IterationMetrics, IterationStep, OcpSolution, utcnow
from alcove.pool import service as pool_service

STEPS = ("train", "ocp", "oracle", "evaluate", "append")


def curve_arrays(k: int, n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    t = np.linspace(0.0, 1.0, n)
    q = (0.232 + 0.1 * np.sin(np.pi * t))[:, None]
    qd = (0.1 * np.pi * np.cos(np.pi * t))[:, None]
    f_true = np.zeros((n, 6))
    f_true[:, 0] = 50.0 * np.clip(q[:, 0] - 0.31, 0, None) / 0.02
    f_true[:, 4] = 0.1 * f_true[:, 0]
    f_pred = f_true + rng.normal(0.0, 5.0 / k, size=f_true.shape)
    return {"t": t, "q": q, "qd": qd, "f_true": f_true, "f_pred": f_pred}


def ocp_arrays(k: int, intervals: int) -> dict[str, np.ndarray]:
    """A two-phase trajectory on a DMOCC-like grid over the preset's 2 s task (1 s + 1 s,
    ``intervals`` per phase): the head moves onto the headrest in phase 1, rests in phase 2."""
    t = np.linspace(0.0, 2.0, 2 * intervals + 1)
    s = np.clip(t, 0.0, 1.0)
    q = (0.05 + (0.232 + 0.001 * k - 0.05) * (3 * s**2 - 2 * s**3))[:, None]
    qd = (np.where(t <= 1.0, (0.232 + 0.001 * k - 0.05) * (6 * s - 6 * s**2), 0.0))[:, None]
    tau = np.where(t < 1.0, 2.0 * (1.0 - 2.0 * s), 0.0)[:, None]
    return {"t": t, "q": q, "qd": qd, "tau": tau, "controls": tau[1:]}


def synthesize_campaign(
    session: Session,
    owner_id: int,
    *,
    iterations: int,
    curve_samples: int = 401,
    pool_samples: int = 100,
    name: str = "synthetic",
    model: bool = False,
    seed: int = 0,
    ocp_intervals: int = 20,
) -> Campaign:
    rng = np.random.default_rng(seed)
    data = CampaignCreate(
        name=name,
        task_version_id=task_version_from_preset(session, owner_id, "head-headrest-2phase"),
        oracle_version_id=oracle_version_for(session, owner_id, "aux-penalty"),
        surrogate_config_version_id=surrogate_config_version_for(session, owner_id, None),
        seed=seed,
        stopping=StoppingRules(max_iterations=iterations),
    )
    c = campaigns.create_campaign(session, owner_id, data)
    cv = c.config_versions[-1] if c.config_versions else None
    cv_id = cv.id if cv is not None else session.info.get("cv")
    start = utcnow() - timedelta(seconds=10 * (iterations + 1))
    parent = None
    for k in range(iterations + 1):
        it = Iteration(
            campaign_id=c.id,
            index=k,
            config_version_id=cv_id,
            status="succeeded",
            started_at=start + timedelta(seconds=10 * k),
            finished_at=start + timedelta(seconds=10 * k + 9),
        )
        session.add(it)
        session.flush()
        for step in ("preliminary",) if k == 0 else STEPS:
            session.add(
                IterationStep(
                    campaign_id=c.id,
                    iteration_id=it.id,
                    step=step,
                    status="succeeded",
                    queue="default",
                    attempts=1,
                    worker_name="synthetic@host",
                    started_at=it.started_at,
                    finished_at=it.finished_at,
                    wall_time_s=1.0,
                    result={},
                )
            )
        n = pool_samples
        tt = np.linspace(0, 1, n)
        qq = 0.2 + 0.2 * rng.random((n, 1))
        ds = pool_service.store_dataset(
            session,
            t=tt,
            q=qq,
            qd=rng.normal(size=(n, 1)),
            f=rng.normal(size=(n, 6)),
            origin="preliminary" if k == 0 else "oracle",
            name=f"k{k}",
            campaign_id=c.id,
            iteration_id=it.id,
        )
        parent = pool_service.create_version(
            session, campaign_id=c.id, iteration_id=it.id, version=k, parent=parent, new_datasets=[ds]
        )
        if k >= 1:
            curves = curve_arrays(k, curve_samples, rng)
            err = curves["f_pred"] - curves["f_true"]
            session.add(
                IterationMetrics(
                    campaign_id=c.id,
                    iteration_id=it.id,
                    iteration_index=k,
                    force_rmse=float(np.sqrt(np.mean(np.sum(err[:, :3] ** 2, axis=1)))),
                    moment_rmse=float(np.sqrt(np.mean(np.sum(err[:, 3:] ** 2, axis=1)))),
                    force_max_error=float(np.abs(err[:, :3]).max()),
                    moment_max_error=float(np.abs(err[:, 3:]).max()),
                    ocp_success=True,
                    ocp_status="Solve_Succeeded",
                    ocp_iterations=30,
                    ocp_cost=1.0 / k,
                    ocp_wall_time_s=2.0,
                    oracle_wall_time_s=3.0,
                    train_wall_time_s=1.0,
                    n_pool_samples=parent.n_samples,
                    dataset_id=ds.id,
                    curves_sha256=put_arrays(session, curves),
                )
            )
            session.add(
                OcpSolution(
                    campaign_id=c.id,
                    iteration_id=it.id,
                    attempt=1,
                    initial_guess="previous" if k > 1 else "default",
                    success=True,
                    solver_status="Solve_Succeeded",
                    n_iterations=30,
                    cost=1.0 / k,
                    wall_time_s=2.0,
                    stats={},
                    trajectory_sha256=put_arrays(session, ocp_arrays(k, ocp_intervals)),
                )
            )
            if model and k == 1:
                _train_tiny_model(session, c, it, parent)
    c.status = "completed"
    c.stop_reason = "max_iterations"
    c.current_iteration = iterations
    c.started_at, c.finished_at = start, utcnow()
    session.flush()
    return c


def _train_tiny_model(session: Session, c: Campaign, it: Iteration, pool_version) -> None:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate
    from alcove.surrogates.service import store_model

    pool = pool_service.load_training_pool(session, pool_version)
    config = SurrogateConfig(max_epochs=3)
    result = train_surrogate(pool, config, seed=0)
    store_model(
        session,
        result,
        campaign_id=c.id,
        iteration_id=it.id,
        version=it.index,
        pool_version_id=pool_version.id,
        parent_model_id=None,
        surrogate_config_version_id=c.surrogate_config_version_id,
        seed=0,
    )
