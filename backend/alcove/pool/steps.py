"""The pool's campaign steps: the preliminary data (pool version 0) and the append of an
iteration's oracle data (pool version k = k-1 + that data). Called by the campaign's job
protocol; see :mod:`alcove.jobs.step_contract`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from sqlalchemy.orm import Session

from alcove.jobs.step_contract import IterationRef, StepOutput, StepRun
from alcove.models import PoolVersion
from alcove.pool import repository as repo
from alcove.pool.service import create_version, store_dataset
from alcove.science.series import stack_wrench


@dataclass(frozen=True)
class PreliminarySpec:
    """Where the preliminary data comes from: Latin-hypercube samples of the auxiliary
    contact model, or datasets uploaded before (``dataset_ids``)."""

    samples: int
    velocity_bound: float
    seed: int
    chunks: int
    dataset_ids: list[int] | None
    meta: dict[str, Any]


def build_preliminary(
    run: StepRun,
    spec: PreliminarySpec,
    preset: Any,
    model: Any = None,
    measured: Callable[[Session, IterationRef], list[Any]] | None = None,
) -> StepOutput:
    """Pool version 0 of a campaign. ``model``: the task's ``ModelSpec`` when it is a chain
    (samples over its joint box, the wrench from its head's pose); None: the 1-DOF ``preset``.
    ``measured``: a write that stores more datasets for version 0 (the oracle's replays of a
    press family) and returns them."""
    pool = None
    if not spec.dataset_ids:
        from alcove.science.surrogate.preliminary import chain_box, chain_preliminary_pool, preliminary_pool

        if model is not None:
            pool = chain_preliminary_pool(
                model.pose_function(),
                model.oracle_preset(),
                chain_box(model.q_initial, model.joint_min, model.joint_max),
                samples=spec.samples,
                velocity_bound=spec.velocity_bound,
                seed=spec.seed,
                chunks=spec.chunks,
            )
        else:
            pool = preliminary_pool(
                preset, samples=spec.samples, velocity_bound=spec.velocity_bound, seed=spec.seed, chunks=spec.chunks
            )
        run.check_cancel()

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        if pool is not None:
            new = [
                store_dataset(
                    s,
                    t=d.t,
                    q=d.q,
                    qd=d.qd,
                    f=stack_wrench(d.force, d.moment),
                    origin="preliminary",
                    name=d.name,
                    campaign_id=at.campaign_id,
                    iteration_id=at.iteration_id,
                    meta=spec.meta,
                )
                for d in pool
            ]
        else:
            new = repo.datasets(s, list(spec.dataset_ids or []))
        if measured is not None:
            new = [*new, *measured(s, at)]
        pv = create_version(
            s, campaign_id=at.campaign_id, iteration_id=at.iteration_id, version=0, parent=None, new_datasets=new
        )
        return {"pool_version_id": pv.id, "n_datasets": pv.n_datasets, "n_samples": pv.n_samples}

    return StepOutput(write)


def append(parent_version: int) -> StepOutput:
    """Pool version k: version ``parent_version`` (k-1, possibly a fork source's) plus the
    datasets the iteration's oracle jobs produced (one per replayed pick, in pick order; none if
    the iteration failed), as one version."""

    def write(s: Session, at: IterationRef) -> dict[str, Any]:
        parent: PoolVersion | None = repo.version_of(s, at.campaign_id, parent_version)
        if parent is None:
            raise RuntimeError(f"pool version {parent_version} does not exist")
        new = repo.oracle_datasets(s, at.iteration_id)
        pv = create_version(
            s,
            campaign_id=at.campaign_id,
            iteration_id=at.iteration_id,
            version=at.index,
            parent=parent,
            new_datasets=new,
        )
        return {
            "pool_version_id": pv.id,
            "n_datasets": pv.n_datasets,
            "n_samples": pv.n_samples,
            "appended": new[0].id if len(new) == 1 else [d.id for d in new] if new else None,
        }

    return StepOutput(write)
