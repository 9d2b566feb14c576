"""Wall time of the OCP solve of the head-headrest task (2 x 100 intervals, DMOCC + IPOPT).

* aux contact, cached NLP: what a repeated solve of one task with one contact costs;
* aux contact, cold: build the NLP, the passive initial guess and solve;
* trained surrogate, cold: a new surrogate every campaign iteration means a new NLP;
* trained surrogate, warm: the same, warm-started from the solution with the previous
  iteration's surrogate (what the campaign engine does).

The surrogates are trained in the setup on the preliminary aux-penalty LHS data (default
architecture; the second warm-started from the first, as in consecutive campaign
iterations). The machine is shared: report the load with the figures.
"""

from __future__ import annotations

import time
from functools import lru_cache
from typing import Any

from bench.harness import figure, timed

TASK = "head-headrest-2phase"


def _aux_setup() -> tuple[Any, Any]:
    from alcove.science.ocp.contact import aux_contact
    from alcove.science.ocp.solve import solve_task
    from alcove.science.ocp.task_spec import task_preset

    task = task_preset(TASK)
    contact = aux_contact(task.preset())
    assert solve_task(task, contact).converged  # builds and caches the NLP
    return task, contact


def _solve(task: Any, contact: Any, cpu: bool = False, **kw: Any) -> float:
    """Wall time (or CPU time of this process, less sensitive to a shared machine's load)."""
    from alcove.science.ocp.solve import solve_task

    def run() -> None:
        solution = solve_task(task, contact, **kw)
        assert solution.converged, solution.status

    if not cpu:
        return timed(run)
    t0 = time.process_time()
    run()
    return time.process_time() - t0


@figure("ocp head-headrest aux contact, 200 intervals (cached NLP)", "s", target=1.0, setup=_aux_setup, reps=7, quick_reps=3, group="ocp")
def ocp_aux_cached(ctx: Any) -> float:
    task, contact = ctx
    return _solve(task, contact)


@figure(
    "ocp head-headrest aux contact, 200 intervals (cold: build + guess + solve)", "s", target=1.0, setup=_aux_setup, reps=5,
    quick_reps=2, group="ocp",
)
def ocp_aux_cold(ctx: Any) -> float:
    from alcove.science.ocp.contact import aux_contact
    from alcove.science.ocp.solve import clear_cache

    task, _ = ctx
    clear_cache()
    return _solve(task, aux_contact(task.preset()))


@lru_cache(maxsize=1)
def _surrogate_setup() -> tuple[Any, Any, Any, Any]:
    from alcove.science.ocp.solve import solve_task
    from alcove.science.ocp.task_spec import task_preset
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.export import casadi_contact_function
    from alcove.science.surrogate.preliminary import preliminary_pool
    from alcove.science.surrogate.training import train_surrogate

    task = task_preset(TASK)
    preset = task.preset()
    pool = preliminary_pool(preset, samples=2000)
    config = SurrogateConfig(max_epochs=200)
    # consecutive campaign iterations: the next model is warm-started from the previous one
    first = train_surrogate(pool, config, seed=0, preset=preset).model
    second = train_surrogate(pool, config, seed=1, preset=preset, warm_start=first).model
    previous, current = (casadi_contact_function(model, preset) for model in (first, second))
    previous_solution = solve_task(task, previous)
    assert previous_solution.converged
    return task, previous, current, previous_solution


@figure(
    "ocp head-headrest trained surrogate, 200 intervals (cold: build + guess + solve)", "s", target=0.5, setup=_surrogate_setup,
    reps=5, quick=False, group="ocp", notes="a new surrogate each campaign iteration: NLP built every time",
)
def ocp_surrogate_cold(ctx: Any) -> float:
    from alcove.science.ocp.solve import clear_cache

    task, _, current, _ = ctx
    clear_cache()
    return _solve(task, current)


@figure(
    "ocp head-headrest trained surrogate, 200 intervals (warm start from the previous surrogate's solution)", "s", target=0.5,
    setup=_surrogate_setup, reps=5, quick=False, group="ocp", notes="the campaign's case: NLP built every time, primal-dual warm start",
)
def ocp_surrogate_warm(ctx: Any) -> float:
    from alcove.science.ocp.solve import clear_cache

    task, _, current, previous_solution = ctx
    clear_cache()
    return _solve(task, current, initial_guess=previous_solution)


@figure(
    "ocp head-headrest trained surrogate, 200 intervals (cold), CPU time", "cpu s", target=0.5, setup=_surrogate_setup,
    reps=5, quick=False, group="ocp", notes="process CPU time of the cold solve: the wall time without the shared machine's queueing",
)
def ocp_surrogate_cold_cpu(ctx: Any) -> float:
    from alcove.science.ocp.solve import clear_cache

    task, _, current, _ = ctx
    clear_cache()
    return _solve(task, current, cpu=True)


@figure(
    "ocp head-headrest trained surrogate, 200 intervals (warm start), CPU time", "cpu s", target=0.5, setup=_surrogate_setup,
    reps=5, quick=False, group="ocp", notes="process CPU time of the warm-started solve",
)
def ocp_surrogate_warm_cpu(ctx: Any) -> float:
    from alcove.science.ocp.solve import clear_cache

    task, _, current, previous_solution = ctx
    clear_cache()
    return _solve(task, current, cpu=True, initial_guess=previous_solution)


@figure(
    "ocp head-headrest aux contact, 200 intervals (cached NLP), CPU time", "cpu s", target=1.0, setup=_aux_setup, reps=7,
    quick_reps=3, group="ocp",
)
def ocp_aux_cached_cpu(ctx: Any) -> float:
    task, contact = ctx
    return _solve(task, contact, cpu=True)
