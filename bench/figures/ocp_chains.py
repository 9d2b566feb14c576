"""Wall and CPU time of the OCP solve of the paper's two-phase task on the 2- and 3-joint chain
presets (group ``ocp-chains``; 200 intervals, cached NLP, one IPOPT run from the passive guess):

* with the aux contact fed by the chain's head pose;
* with a trained surrogate (K = 5, trained in the setup on the chain's preliminary aux data, its
  features from the chain's head pose, the weights as NLP parameters, as in a campaign).

The machine is shared: report the load with the figures; the CPU-time figures are less
sensitive to it.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

from bench.figures.ocp import TASK, _solve
from bench.harness import figure


def _chain_setup(preset: str) -> tuple[Any, Any]:
    """The paper's two-phase task on an n-DOF chain preset with the aux contact fed by the head pose."""
    from alcove.science.ocp.contact import chain_aux_contact
    from alcove.science.ocp.solve import solve_task
    from alcove.science.ocp.task_spec import parse_task, task_preset

    data = task_preset(TASK).model_dump(mode="json")
    data["model"] = {"preset": preset}
    task = parse_task(data)
    contact = chain_aux_contact(task.chain())
    assert solve_task(task, contact).converged  # builds and caches the NLP
    return task, contact


@figure(
    "ocp head-headrest on head-neck-2dof, aux contact, 200 intervals (cached NLP)",
    "s",
    target=1.0,
    setup=lambda: _chain_setup("head-neck-2dof"),
    reps=5,
    quick_reps=2,
    group="ocp-chains",
)
def ocp_chain_2dof_cached(ctx: Any) -> float:
    task, contact = ctx
    return _solve(task, contact)


@figure(
    "ocp head-headrest on trunk-neck-head-3dof, aux contact, 200 intervals (cached NLP)",
    "s",
    target=2.0,
    setup=lambda: _chain_setup("trunk-neck-head-3dof"),
    reps=5,
    quick_reps=2,
    group="ocp-chains",
)
def ocp_chain_3dof_cached(ctx: Any) -> float:
    task, contact = ctx
    return _solve(task, contact)


@lru_cache(maxsize=2)
def _chain_surrogate_setup(preset: str) -> dict[str, Any]:
    """A K = 5 surrogate trained on the chain's preliminary aux data (features from its head's
    pose; 2000 samples, as the 1-DOF figures), its contact on the chain, the NLP built once."""
    from alcove.science.ocp.solve import solve_task
    from alcove.science.ocp.task_spec import parse_task, task_preset
    from alcove.science.surrogate.casadi_contact import surrogate_contact
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.preliminary import chain_box, chain_preliminary_pool
    from alcove.science.surrogate.training import pose_kinematics, train_surrogate

    data = task_preset(TASK).model_dump(mode="json")
    data["model"] = {"preset": preset}
    task = parse_task(data)
    m, chain = task.model, task.chain()
    pose, head = m.pose_function(), m.oracle_preset()
    pool = chain_preliminary_pool(pose, head, chain_box(m.q_initial, m.joint_min, m.joint_max), samples=2000)
    config = SurrogateConfig(max_epochs=200, ensemble_size=5)
    model = train_surrogate(pool, config, seed=0, preset=head, kinematics=pose_kinematics(pose)).model
    contact, params = surrogate_contact(model, head, chain)
    assert solve_task(task, contact, contact_params=params).converged  # builds and caches the NLP
    return {"task": task, "contact": contact, "params": params}


@figure(
    "ocp head-headrest on head-neck-2dof, trained surrogate K = 5, 200 intervals (cached NLP, passive guess)",
    "s",
    target=1.0,
    setup=lambda: _chain_surrogate_setup("head-neck-2dof"),
    reps=5,
    quick_reps=2,
    group="ocp-chains",
    notes="the surrogate's features from the chain's head pose; weights as NLP parameters",
)
def ocp_chain_2dof_surrogate(ctx: dict[str, Any]) -> float:
    return _solve(ctx["task"], ctx["contact"], contact_params=ctx["params"])


@figure(
    "ocp head-headrest on head-neck-2dof, trained surrogate K = 5, 200 intervals (cached NLP), CPU time",
    "cpu s",
    target=1.0,
    setup=lambda: _chain_surrogate_setup("head-neck-2dof"),
    reps=5,
    quick_reps=2,
    group="ocp-chains",
)
def ocp_chain_2dof_surrogate_cpu(ctx: dict[str, Any]) -> float:
    return _solve(ctx["task"], ctx["contact"], cpu=True, contact_params=ctx["params"])


@figure(
    "ocp head-headrest on trunk-neck-head-3dof, trained surrogate K = 5, 200 intervals (cached NLP, passive guess)",
    "s",
    target=2.0,
    setup=lambda: _chain_surrogate_setup("trunk-neck-head-3dof"),
    reps=5,
    quick_reps=2,
    group="ocp-chains",
    notes="the surrogate's features from the chain's head pose; weights as NLP parameters",
)
def ocp_chain_3dof_surrogate(ctx: dict[str, Any]) -> float:
    return _solve(ctx["task"], ctx["contact"], contact_params=ctx["params"])


@figure(
    "ocp head-headrest on trunk-neck-head-3dof, trained surrogate K = 5, 200 intervals (cached NLP), CPU time",
    "cpu s",
    target=2.0,
    setup=lambda: _chain_surrogate_setup("trunk-neck-head-3dof"),
    reps=5,
    quick_reps=2,
    group="ocp-chains",
)
def ocp_chain_3dof_surrogate_cpu(ctx: dict[str, Any]) -> float:
    return _solve(ctx["task"], ctx["contact"], cpu=True, contact_params=ctx["params"])


@figure(
    "ocp head-headrest on head-neck-2dof, aux contact, 200 intervals (cached NLP), CPU time",
    "cpu s",
    target=1.0,
    setup=lambda: _chain_setup("head-neck-2dof"),
    reps=5,
    quick_reps=2,
    group="ocp-chains",
)
def ocp_chain_2dof_cached_cpu(ctx: Any) -> float:
    task, contact = ctx
    return _solve(task, contact, cpu=True)


@figure(
    "ocp head-headrest on trunk-neck-head-3dof, aux contact, 200 intervals (cached NLP), CPU time",
    "cpu s",
    target=2.0,
    setup=lambda: _chain_setup("trunk-neck-head-3dof"),
    reps=5,
    quick_reps=2,
    group="ocp-chains",
)
def ocp_chain_3dof_cached_cpu(ctx: Any) -> float:
    task, contact = ctx
    return _solve(task, contact, cpu=True)
