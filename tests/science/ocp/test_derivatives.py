"""The structured (local-block) Jacobian and Hessian equal CasADi's automatic ones."""

import casadi as ca
import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET
from alcove.science.multibody import Headrest, Link, PlanarChain
from alcove.science.ocp.contact import aux_contact
from alcove.science.ocp.dmocc import Transcription
from alcove.science.ocp.problem import DiscreteProblem, PhaseGrid


def derivatives(tr: Transcription, x: np.ndarray, lam_f: float, lam_g: np.ndarray):
    if tr.derivatives == "structured":
        jac, hess = tr._derivative_options["jac_g"], tr._derivative_options["hess_lag"]
    else:
        jac, hess = tr.solver.get_function("nlp_jac_g"), tr.solver.get_function("nlp_hess_l")
    J = np.asarray(ca.densify(jac(x, [])[1]))
    H = np.triu(np.asarray(ca.densify(hess(x, [], lam_f, lam_g))))
    return J, H


def compare(chain, problem, contact=None, seed=0, path=None):
    auto = Transcription(chain, problem, contact, derivatives="casadi", path=path, path_upper=1.0)
    mine = Transcription(chain, problem, contact, path=path, path_upper=1.0)
    assert mine.derivatives == "structured"
    rng = np.random.default_rng(seed)
    n, N = chain.ndof, problem.intervals
    x = np.concatenate([rng.uniform(0.25, 0.4, n * (N + 1)), rng.normal(size=n * N)])
    lam_g = rng.normal(size=np.size(auto.lbg))
    (Ja, Ha), (Jm, Hm) = derivatives(auto, x, 0.7, lam_g), derivatives(mine, x, 0.7, lam_g)
    np.testing.assert_allclose(Jm, Ja, rtol=1e-10, atol=1e-10 * np.abs(Ja).max())
    np.testing.assert_allclose(Hm, Ha, rtol=1e-10, atol=1e-10 * np.abs(Ha).max())
    assert np.abs(Ha).max() > 0


@pytest.mark.parametrize(
    "qd_start, qd_end, endpoint",
    [
        (np.zeros(1), np.zeros(1), {}),
        (None, np.zeros(1), {"endpoint_w_q": 2.0, "endpoint_q_ref": np.array([0.3])}),
        (np.array([0.4]), None, {"endpoint_w_qd": 0.7}),
    ],
)
def test_head_task_with_aux_contact(qd_start, qd_end, endpoint):
    chain = PlanarChain.from_preset(DEFAULT_PRESET)
    lo, hi, t = np.array([0.032]), np.array([0.432]), np.array([30.0])
    phases = (PhaseGrid(0.3, 6, 1e-3, 1e-4, lo, hi, t), PhaseGrid(0.5, 4, 1.0, 1.0, lo, hi, t))
    problem = DiscreteProblem(phases, np.array([0.232]), qd_start, None, qd_end, **endpoint)
    compare(chain, problem, aux_contact(DEFAULT_PRESET))


def test_three_link_chain_with_everything():
    links = (Link(4.0, 0.2, 0.05, 0.45), Link(2.5, 0.15, 0.02, 0.3), Link(1.2, 0.1, 0.01, 0.2))
    chain = PlanarChain(links, (-3,) * 3, (3,) * 3, (50,) * 3, headrest=Headrest((-0.3, 0.6), 0.2))
    big = np.full(3, 10.0)
    phases = (PhaseGrid(0.2, 3, 0.5, 0.1, -big, big, big), PhaseGrid(0.4, 5, 1.0, 2.0, -big, big, big))
    problem = DiscreteProblem(phases, None, None, None, np.array([0.1, 0.0, -0.2]), 1.5, np.array([0.3, 0.2, 0.1]), 0.8)
    compare(chain, problem, seed=3)


def _path_function(ndof: int) -> ca.Function:
    """A nonlinear scalar of the midpoint state (q, qd), as the trust region's variance is."""
    q, qd = ca.SX.sym("q", ndof), ca.SX.sym("qd", ndof)
    value = ca.sum1(ca.sin(3 * q) ** 2 * qd**2) + ca.exp(ca.sum1(q * qd)) + ca.sum1(q) ** 3
    return ca.Function("path", [q, qd], [value])


def test_path_constraint_derivatives_are_structured_and_exact():
    """The trust region's path rows (one per interval) in the structured Jacobian and Hessian."""
    chain = PlanarChain.from_preset(DEFAULT_PRESET)
    lo, hi, t = np.array([0.032]), np.array([0.432]), np.array([30.0])
    phases = (PhaseGrid(0.3, 6, 1e-3, 1e-4, lo, hi, t), PhaseGrid(0.5, 4, 1.0, 1.0, lo, hi, t))
    problem = DiscreteProblem(phases, np.array([0.232]), np.zeros(1), None, np.zeros(1))
    compare(chain, problem, aux_contact(DEFAULT_PRESET), path=_path_function(1))
    links = (Link(4.0, 0.2, 0.05, 0.45), Link(2.5, 0.15, 0.02, 0.3))
    two = PlanarChain(links, (-3,) * 2, (3,) * 2, (50,) * 2, headrest=Headrest((-0.3, 0.6), 0.2))
    big = np.full(2, 10.0)
    phases2 = (PhaseGrid(0.2, 3, 0.5, 0.1, -big, big, big), PhaseGrid(0.4, 4, 1.0, 2.0, -big, big, big))
    compare(two, DiscreteProblem(phases2, None, None, None, np.array([0.1, 0.0])), seed=5, path=_path_function(2))
