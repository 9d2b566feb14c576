"""The OCP with a surrogate with memory against the state-only surrogate, on the same data.

The head-headrest task (2 x 100 intervals), the surrogate K = 5 with the paper's features and with
the history features (:mod:`alcove.science.surrogate.history`), both trained on the same pool: the
preliminary aux-penalty LHS data and 12 press-family motions with the auxiliary law's normal force
and a friction force that remembers the slip direction (the law of ``tests/science/ocp``). Each
figure solves the next model version with its NLP cached, from the passive guess (as
``ocp head-headrest trained surrogate ... (next model version, cached NLP, passive guess)``). The
history NLP has 3 more unknowns and constraint rows per interval (the states and their
recursion) and takes CasADi's derivatives instead of the structured blocks.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

from bench.figures.ocp import _solve
from bench.harness import figure

TASK = "head-headrest-2phase"


@lru_cache(maxsize=1)
def _setup() -> dict[str, Any]:
    import numpy as np

    from alcove.science.geometry import relative_kinematics
    from alcove.science.ocp.task_spec import task_preset
    from alcove.science.oracles.aux_penalty import AuxPenaltyParams, aux_penalty_wrench
    from alcove.science.press_family import PressFamily, family_motions
    from alcove.science.surrogate.casadi_contact import surrogate_contact, surrogate_history
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.dataset import PoolDataset
    from alcove.science.surrogate.history import HistoryConfig, history_states
    from alcove.science.surrogate.preliminary import preliminary_pool
    from alcove.science.surrogate.training import train_surrogate

    task = task_preset(TASK)
    preset = task.preset()
    pool = preliminary_pool(preset, samples=2000)
    for i, m in enumerate(family_motions(PressFamily(), 12, list(range(12)), (preset.theta_min, preset.theta_max))):
        tr = m.trajectory(0.0025)
        kin = relative_kinematics(preset, tr.q[:, 0], tr.qd[:, 0])
        force, moment = aux_penalty_wrench(preset, AuxPenaltyParams(), kin)
        slip = history_states(preset, kin, tr.t, HistoryConfig())[:, 2]
        force[:, 2] = -0.4 * force[:, 0] * np.tanh(slip / 5e-3)
        pool.append(PoolDataset(f"press-{i:02d}", tr.t, tr.q, tr.qd, force, moment))
    out: dict[str, Any] = {"task": task}
    for features in ("paper", "history"):
        config = SurrogateConfig(max_epochs=200, ensemble_size=5, features=features)
        model = train_surrogate(pool, config, seed=0, preset=preset).model
        contact, params = surrogate_contact(model, preset)
        history = surrogate_history(model, preset)
        _solve(task, contact, contact_params=params, history=history)  # builds and caches the NLP
        out[features] = {"contact": contact, "params": params, "history": history}
    return out


def _run(ctx: dict[str, Any], features: str, cpu: bool) -> float:
    c = ctx[features]
    return _solve(ctx["task"], c["contact"], cpu=cpu, contact_params=c["params"], history=c["history"])


@figure(
    "ocp head-headrest surrogate K = 5 paper features, 200 intervals (same data as history, cached NLP), CPU time",
    "cpu s",
    target=1.0,
    setup=_setup,
    reps=5,
    quick=False,
    group="ocp",
    notes="the state-only twin of the next figure, trained on the same pool",
)
def ocp_paper_twin_cpu(ctx: dict[str, Any]) -> float:
    return _run(ctx, "paper", cpu=True)


@figure(
    "ocp head-headrest surrogate K = 5 history features, 200 intervals (cached NLP), CPU time",
    "cpu s",
    target=2.0,
    setup=_setup,
    reps=5,
    quick=False,
    group="ocp",
    notes="target: at most 2x the paper twin's CPU time (about 1 s); 3 history states per interval as unknowns "
    "with their recursion as constraints, CasADi's derivatives",
)
def ocp_history_cpu(ctx: dict[str, Any]) -> float:
    return _run(ctx, "history", cpu=True)
