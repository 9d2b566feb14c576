"""The ocp slot of strategy ``press-family`` (:mod:`alcove.science.ocp.acquisition`): no OCP is
solved; the slot's solution is a prescribed motion of the task's press family, which the oracle
slot then replays whole."""

from __future__ import annotations

from dataclasses import asdict
from typing import TYPE_CHECKING, Any

from alcove.campaigns import candidate_queries
from alcove.campaigns import repository as repo
from alcove.campaigns.run import candidate_writes
from alcove.campaigns.suite import family_box, suite_model
from alcove.db import open_transaction
from alcove.jobs.step_contract import StepOutput
from alcove.science.ocp import acquisition
from alcove.science.ocp.scenarios import Scenario
from alcove.solving import steps as solving_steps
from alcove.surrogates import repository as surrogates_repo

if TYPE_CHECKING:
    from alcove.campaigns.run.step_context import StepContext


def _family_motions(settings: Any, task: Any, seed: int, indices: list[int]) -> tuple[Any, list[tuple[Any, Any]]]:
    """The family's box for ``task`` and, per sequence index, the motion and its trajectory
    sampled at the replay step (a chain's along its suite's joint line)."""
    from alcove.science.press_family import sequence_motion
    from alcove.science.validation_suite import ChainSuiteModel, chain_press_trajectory

    model = suite_model(task)
    box = family_box(settings, task, model)
    dt = settings.replay_dt or 0.0025
    out = []
    for i in indices:
        motion = sequence_motion(box, seed, i, (model.theta_min, model.theta_max))
        if isinstance(model, ChainSuiteModel):
            out.append((motion, chain_press_trajectory(motion, dt, model, task.model.pose_function())))
        else:
            out.append((motion, motion.trajectory(dt)))
    return box, out


def family_motion(ctx: StepContext) -> StepOutput:
    """The ocp slot of strategy ``press-family``: the next motion of the task's press family
    (:func:`alcove.science.press_family.sequence_motion`, seeded by the campaign seed) as the slot's
    prescribed solution, and its candidate row (the motion, its sequence index and its point in
    the family's box scaled to [0, 1], picked at once)."""
    from alcove.science.press_family import PARAMETERS

    with open_transaction() as s:
        c = repo.get_campaign(s, ctx.campaign_id)
        mv = surrogates_repo.version_of(s, c.id, ctx.k)
        if mv is None:
            raise RuntimeError(f"model version {ctx.k} does not exist")
        task, seed = ctx.task(s, c), c.seed
        # the preliminary replays are the sequence's first motions; the iterations' follow them
        used = [*range(ctx.config.preliminary.family_replays), *candidate_queries.family_motion_indices(s, c.id, ctx.k)]
    settings = ctx.config.settings
    index = acquisition.family_motion_index(used, ctx.ref.slot)
    box, ((motion, traj),) = _family_motions(settings, task, seed, [index])
    features = []
    for name in PARAMETERS:
        lo, hi = getattr(box, name)
        features.append(float((getattr(motion, name) - lo) / (hi - lo)) if hi > lo else 0.0)
    # the nominal task's headrest (no drawn values), and the motion the oracle replays
    nominal = Scenario(task=task, seed=seed, iteration=ctx.k, slot=ctx.ref.slot).to_json()
    stored = {**nominal, "motion": asdict(motion), "motion_index": index}
    out = solving_steps.prescribe(ctx.run, t=traj.t, q=traj.q, qd=traj.qd, model_version_id=mv.id, motion=stored)
    return StepOutput(candidate_writes.storing_scenario(out.write, stored, features, settings.strategy), out.compute_s)


def preliminary_replays(ctx: StepContext, task: Any, seed: int, oracle_version_id: int) -> Any:
    """The write of pool version 0's press-family replays: the first ``preliminary.family_motions``
    motions of the family's sequence replayed by the oracle (:func:`alcove.oracles.steps.replay_motions`)."""
    from alcove.oracles import steps as oracle_steps

    _, motions = _family_motions(ctx.config.settings, task, seed, list(range(ctx.config.preliminary.family_replays)))
    return oracle_steps.replay_motions(
        ctx.run,
        oracle_version_id=oracle_version_id,
        preset=task.model.oracle_preset(),
        trajectories=[traj for _, traj in motions],
        label="press-family",
    )
