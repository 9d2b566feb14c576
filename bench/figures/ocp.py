"""Wall time of the OCP solve of the head-headrest task (2 x 100 intervals, DMOCC + IPOPT).

* aux contact, cached NLP: what a repeated solve of one task with one contact costs;
* aux contact, cold: build the NLP, the passive initial guess and solve;
* trained surrogate, cold: the first solve in a fresh process (a new Python process runs
  the export, the NLP and solver build, the passive initial guess and IPOPT; the figure is
  the time of those, measured inside that process: interpreter start-up and imports, which
  a worker pays once, are excluded);
* trained surrogate, warm: the next model version in the same process, as in a campaign:
  the weights are NLP parameters (``surrogate_contact``), so the NLP and solver built for the
  previous version are reused and IPOPT is warm-started from the previous version's solution;
* trained surrogate, new version from the passive guess: the same without the warm start;
* the same task on the 2- and 3-joint chain presets: ``bench/figures/ocp_chains.py``.

The surrogates are trained in the setup on the preliminary aux-penalty LHS data (default
architecture and ensemble size K = 5, so the contact model is the mean of five member pairs;
the second warm-started from the first, as in consecutive campaign iterations). The machine
is shared: report the load with the figures; the CPU-time figures are less sensitive to it.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from functools import lru_cache
from pathlib import Path
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


@figure(
    "ocp head-headrest aux contact, 200 intervals (cached NLP)",
    "s",
    target=1.0,
    setup=_aux_setup,
    reps=7,
    quick_reps=3,
    group="ocp",
)
def ocp_aux_cached(ctx: Any) -> float:
    task, contact = ctx
    return _solve(task, contact)


@figure(
    "ocp head-headrest aux contact, 200 intervals (cold: build + guess + solve)",
    "s",
    target=1.0,
    setup=_aux_setup,
    reps=5,
    quick_reps=2,
    group="ocp",
)
def ocp_aux_cold(ctx: Any) -> float:
    from alcove.science.ocp.contact import aux_contact
    from alcove.science.ocp.solve import clear_cache

    task, _ = ctx
    clear_cache()
    return _solve(task, aux_contact(task.preset()))


@lru_cache(maxsize=1)
def _surrogate_setup() -> dict[str, Any]:
    from alcove.science.ocp.solve import solve_task
    from alcove.science.ocp.task_spec import task_preset
    from alcove.science.surrogate.artifact import save_artifact
    from alcove.science.surrogate.casadi_contact import surrogate_contact
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.preliminary import preliminary_pool
    from alcove.science.surrogate.training import train_surrogate

    task = task_preset(TASK)
    preset = task.preset()
    pool = preliminary_pool(preset, samples=2000)
    config = SurrogateConfig(max_epochs=200, ensemble_size=5)
    # consecutive campaign iterations: the next model is warm-started from the previous one
    first = train_surrogate(pool, config, seed=0, preset=preset).model
    second = train_surrogate(pool, config, seed=1, preset=preset, warm_start=first).model
    directory = Path(tempfile.mkdtemp(prefix="alcove-bench-ocp-"))
    save_artifact(second, directory / "current")
    (contact, previous_params), (_, current_params) = (surrogate_contact(m, preset) for m in (first, second))
    previous_solution = solve_task(task, contact, contact_params=previous_params)  # builds and caches the NLP
    assert previous_solution.converged
    return {
        "task": task,
        "contact": contact,
        "previous": previous_params,
        "current": current_params,
        "previous_solution": previous_solution,
        "artifact": directory / "current",
    }


def _fresh_process(artifact: Path) -> dict[str, Any]:
    """Run :func:`_first_solve` in a new Python process."""
    out = subprocess.run(
        [sys.executable, "-m", "bench.figures.ocp", str(artifact)],
        capture_output=True,
        text=True,
        check=True,
        cwd=Path(__file__).resolve().parents[2],
    )
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["converged"], result
    return result


def _first_solve(artifact: str) -> dict[str, Any]:
    """In a fresh process (imports done, model loaded): export + NLP build + guess + solve."""
    from alcove.science.ocp.solve import solve_task
    from alcove.science.ocp.task_spec import task_preset
    from alcove.science.surrogate.artifact import load_artifact
    from alcove.science.surrogate.casadi_contact import surrogate_contact

    task = task_preset(TASK)
    model = load_artifact(artifact)
    wall, cpu = time.perf_counter(), time.process_time()
    contact, params = surrogate_contact(model, task.preset())
    solution = solve_task(task, contact, contact_params=params)
    return {
        "wall_s": time.perf_counter() - wall,
        "cpu_s": time.process_time() - cpu,
        "converged": solution.converged,
        "iterations": solution.iterations,
    }


@figure(
    "ocp head-headrest trained surrogate K = 5, 200 intervals (cold: first solve in a fresh process)",
    "s",
    target=1.0,
    setup=_surrogate_setup,
    reps=5,
    quick=False,
    group="ocp",
    notes="export + NLP/solver build + passive guess + IPOPT, timed inside a new process (imports excluded)",
)
def ocp_surrogate_cold(ctx: dict[str, Any]) -> float:
    return float(_fresh_process(ctx["artifact"])["wall_s"])


@figure(
    "ocp head-headrest trained surrogate K = 5, 200 intervals (warm: next model version, cached NLP, warm start)",
    "s",
    target=1.0,
    setup=_surrogate_setup,
    reps=5,
    quick=False,
    group="ocp",
    notes="the campaign's case: weights as NLP parameters, primal-dual warm start from the previous version's solution",
)
def ocp_surrogate_warm(ctx: dict[str, Any]) -> float:
    return _solve(ctx["task"], ctx["contact"], contact_params=ctx["current"], initial_guess=ctx["previous_solution"])


@figure(
    "ocp head-headrest trained surrogate K = 5, 200 intervals (next model version, cached NLP, passive guess)",
    "s",
    target=1.0,
    setup=_surrogate_setup,
    reps=5,
    quick=False,
    group="ocp",
    notes="as warm, without a previous solution",
)
def ocp_surrogate_cached_nlp(ctx: dict[str, Any]) -> float:
    return _solve(ctx["task"], ctx["contact"], contact_params=ctx["current"])


@figure(
    "ocp head-headrest trained surrogate K = 5, 200 intervals (cold: fresh process), CPU time",
    "cpu s",
    target=1.0,
    setup=_surrogate_setup,
    reps=5,
    quick=False,
    group="ocp",
    notes="process CPU time of the cold solve, measured in the new process",
)
def ocp_surrogate_cold_cpu(ctx: dict[str, Any]) -> float:
    return float(_fresh_process(ctx["artifact"])["cpu_s"])


@figure(
    "ocp head-headrest trained surrogate K = 5, 200 intervals (warm), CPU time",
    "cpu s",
    target=1.0,
    setup=_surrogate_setup,
    reps=5,
    quick=False,
    group="ocp",
    notes="process CPU time of the warm solve",
)
def ocp_surrogate_warm_cpu(ctx: dict[str, Any]) -> float:
    return _solve(
        ctx["task"], ctx["contact"], cpu=True, contact_params=ctx["current"], initial_guess=ctx["previous_solution"]
    )


@figure(
    "ocp head-headrest aux contact, 200 intervals (cached NLP), CPU time",
    "cpu s",
    target=1.0,
    setup=_aux_setup,
    reps=7,
    quick_reps=3,
    group="ocp",
)
def ocp_aux_cached_cpu(ctx: Any) -> float:
    task, contact = ctx
    return _solve(task, contact, cpu=True)


@lru_cache(maxsize=1)
def _trust_region_setup() -> dict[str, Any]:
    """The surrogate setup plus the trust region, its NLP built once. The bound lies midway between
    the ensemble force std at the start state (fixed by the task: a lower bound is infeasible) and
    the largest std along the unbounded solution (so the bound is active)."""
    import numpy as np

    from alcove.science.surrogate.artifact import load_artifact
    from alcove.science.surrogate.casadi_contact import surrogate_contact_std
    from alcove.science.surrogate.trust import force_variance_function, trust_curves

    ctx = dict(_surrogate_setup())
    task = ctx["task"]
    model = load_artifact(ctx["artifact"])
    free = ctx["previous_solution"]
    preset = task.preset()
    free_max = float(trust_curves(model, preset, free.t, free.q).force_std.max())
    at_rest = np.full((2, 1), float(task.discrete_problem().q_start[0]))
    start = float(trust_curves(model, preset, np.array([0.0, 1.0]), at_rest).force_std[0])
    bound = start + 0.5 * (free_max - start)
    std_fn, _ = surrogate_contact_std(model, task.preset())
    ctx["path"] = (force_variance_function(std_fn), bound**2)
    _solve(task, ctx["contact"], contact_params=ctx["current"], path=ctx["path"])  # builds and caches the NLP
    return ctx


@figure(
    "ocp head-headrest trained surrogate K = 5, 200 intervals, trust region (cached NLP, default guesses)",
    "s",
    target=1.0,
    setup=_trust_region_setup,
    reps=3,
    quick=False,
    group="ocp",
    notes="ensemble force variance <= bound^2 at every interval midpoint, the bound midway between the start "
    "state's std and the unbounded solution's maximum; structured derivatives, the path term's Hessian "
    "convexified, mu_init 1e-6; first guess: holding still; the interval maps on one thread per usable CPU "
    "(alcove.science.parallel.grid_map)",
)
def ocp_surrogate_trust_region(ctx: dict[str, Any]) -> float:
    return _solve(ctx["task"], ctx["contact"], contact_params=ctx["current"], path=ctx["path"])


@figure(
    "ocp head-headrest trained surrogate K = 5, 200 intervals, trust region (cached NLP), CPU time",
    "cpu s",
    target=1.0,
    setup=_trust_region_setup,
    reps=3,
    quick=False,
    group="ocp",
    notes="process CPU time of the trust-region solve",
)
def ocp_surrogate_trust_region_cpu(ctx: dict[str, Any]) -> float:
    return _solve(ctx["task"], ctx["contact"], cpu=True, contact_params=ctx["current"], path=ctx["path"])


if __name__ == "__main__":  # the fresh process of the cold figures
    print(json.dumps(_first_solve(sys.argv[1])))
