"""The OCP's exploration term: the cost rewards the ensemble's disagreement along the motion.

Optimality gives a law to test: the solution with weight 0 minimises the task's own cost, so a
solution with weight w > 0 has a task cost at least as large (the price of exploring) and a
larger reward (the integral of the force variance it was solved to increase); the larger w, the
more disagreement the motion seeks (checked at two weights). Weight 0 is the paper's OCP, bit
for bit."""

from __future__ import annotations

import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.ocp.solve import solve_task
from alcove.science.ocp.task_spec import TASK_PRESETS, parse_task
from alcove.science.surrogate.casadi_contact import surrogate_contact, surrogate_contact_std
from alcove.science.surrogate.trust import force_variance_function

pytestmark = pytest.mark.slow


def _reward(variance, params, sol) -> float:
    """sum_k h_k sigma_F^2 at the interval midpoints, as the OCP's term evaluates it."""
    q, t = sol.q, sol.t
    h = np.diff(t)
    mid, v = 0.5 * (q[1:] + q[:-1]), (q[1:] - q[:-1]) / h[:, None]
    values = [float(variance(mid[k], v[k], params)) for k in range(len(h))]
    return float(np.sum(h * np.array(values)))


def test_exploring_costs_task_cost_and_buys_disagreement_growing_with_the_weight(ghost_case):
    model, _ = ghost_case
    task = parse_task({**TASK_PRESETS["head-headrest-2phase"], "initial": {"q": [0.06], "qd": None}}).with_intervals(20)
    fn, p = surrogate_contact(model, P)
    std_fn, _ = surrogate_contact_std(model, P)
    variance = force_variance_function(std_fn)
    plain = solve_task(task, fn, contact_params=p)
    zero = solve_task(task, fn, contact_params=p, exploration=(variance, 0.0))
    assert plain.converged and np.array_equal(zero.x, plain.x)  # weight 0: the paper's OCP
    rewards, task_costs = [_reward(variance, p, plain)], [plain.cost]
    for w in (1e-6, 1e-5):  # 1/(N^2 s); the task's own cost is about 1e-5
        sol = solve_task(task, fn, contact_params=p, exploration=(variance, w))
        assert sol.converged, sol.status
        r = _reward(variance, p, sol)
        rewards.append(r)
        task_costs.append(sol.cost + w * r)  # the reported cost includes the reward; the task's is without it
    # optimality: each exploring motion pays in the task's own cost and gains disagreement
    assert all(c >= task_costs[0] * (1 - 1e-6) for c in task_costs[1:]), task_costs
    assert rewards[1] > rewards[0] and rewards[2] > 2 * rewards[0], rewards
    assert rewards[2] > rewards[1]
