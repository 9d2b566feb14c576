"""The structured (local-block) Jacobian and Hessian equal CasADi's automatic ones."""

import casadi as ca
import numpy as np
import pytest

from alcove.science.geometry import DEFAULT_PRESET
from alcove.science.multibody import Headrest, Link, PlanarChain
from alcove.science.ocp.contact import aux_contact
from alcove.science.ocp.dmocc import Transcription
from alcove.science.ocp.problem import DiscreteProblem, PhaseGrid


def derivatives(tr: Transcription, x: np.ndarray, lam_f: float, lam_g: np.ndarray, par=()):
    if tr.derivatives == "structured":
        jac, hess = tr._derivative_options["jac_g"], tr._derivative_options["hess_lag"]
    else:
        jac, hess = tr.solver.get_function("nlp_jac_g"), tr.solver.get_function("nlp_hess_l")
    J = np.asarray(ca.densify(jac(x, par)[1]))
    H = np.triu(np.asarray(ca.densify(hess(x, par, lam_f, lam_g))))
    return J, H


def compare(chain, problem, contact=None, seed=0, path=None, par=(), q_range=(0.25, 0.4)):
    auto = Transcription(chain, problem, contact, derivatives="casadi", path=path, path_upper=1.0)
    mine = Transcription(chain, problem, contact, path=path, path_upper=1.0, path_hessian="exact")
    assert mine.derivatives == "structured"
    rng = np.random.default_rng(seed)
    n, N = chain.ndof, problem.intervals
    x = np.concatenate([rng.uniform(*q_range, n * (N + 1)), rng.normal(size=n * N)])
    lam_g = rng.normal(size=np.size(auto.lbg))
    (Ja, Ha), (Jm, Hm) = derivatives(auto, x, 0.7, lam_g, par), derivatives(mine, x, 0.7, lam_g, par)
    # the constraint values jac_g returns (assembled from the local blocks) are the NLP's g
    g_auto = np.asarray(auto.solver.get_function("nlp_g")(x, par)).ravel()
    np.testing.assert_allclose(
        np.asarray(mine._derivative_options["jac_g"](x, par)[0]).ravel(),
        g_auto,
        rtol=1e-12,
        atol=1e-12 * np.abs(g_auto).max(),
    )
    np.testing.assert_allclose(
        np.asarray(mine.solver.get_function("nlp_g")(x, par)).ravel(),
        g_auto,
        rtol=1e-12,
        atol=1e-12 * np.abs(g_auto).max(),
    )
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


def _ensemble_problem():
    """A K = 3 ensemble contact with random weights, its force variance as the path function, and
    a short head-headrest problem: (chain, problem, contact, path, par, preset)."""
    import torch

    from alcove.science.geometry import relative_kinematics
    from alcove.science.surrogate.casadi_contact import surrogate_contact, surrogate_contact_std
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.features import features
    from alcove.science.surrogate.mlp import MLP, Member, Standardization, SurrogateModel
    from alcove.science.surrogate.trust import force_variance_function

    P = DEFAULT_PRESET
    cfg = SurrogateConfig(ensemble_size=3)
    rng = np.random.default_rng(4)
    th = rng.uniform(P.theta_min, P.theta_max, 300)
    x_norm = Standardization.fit(features(relative_kinematics(P, th, rng.uniform(-2, 2, 300))))
    members = []
    for k in range(3):
        g = torch.Generator().manual_seed(k)
        nets = [MLP.from_config(cfg.force), MLP.from_config(cfg.moment)]
        for net in nets:
            net.reset_parameters(g)
        out = Standardization(rng.normal(size=3), np.array([40.0, 1.0, 5.0]))
        members.append(Member(nets[0], nets[1], x_norm, out, Standardization(rng.normal(size=3), np.ones(3))))
    model = SurrogateModel.from_members(members, cfg, P)
    contact, par = surrogate_contact(model, P)
    std_fn, _ = surrogate_contact_std(model, P)
    path = force_variance_function(std_fn)
    chain = PlanarChain.from_preset(P)
    lo, hi, t = np.array([P.theta_min]), np.array([P.theta_max]), np.array([30.0])
    phases = (PhaseGrid(0.3, 5, 1e-3, 1e-4, lo, hi, t), PhaseGrid(0.5, 4, 1.0, 1.0, lo, hi, t))
    problem = DiscreteProblem(phases, np.array([0.5 * (P.theta_min + P.theta_max)]), np.zeros(1), None, np.zeros(1))
    return chain, problem, contact, path, par, P


def test_ensemble_contact_and_its_variance_evaluate_each_member_once_and_stay_exact():
    """The trust region on an ensemble: the contact (the members' mean) and the path constraint
    (their force variance) evaluate the same member networks. The structured derivatives build
    both in one graph with the common members merged: exact against CasADi's own derivatives
    (weights as NLP parameters), and smaller than the two graphs apart."""
    chain, problem, contact, path, par, P = _ensemble_problem()
    compare(chain, problem, contact, seed=2, path=path, par=par, q_range=(P.theta_min, P.theta_max))

    def local_jac_size(path):
        tr = Transcription(chain, problem, contact, path=path, path_upper=1.0)
        return next(
            f for f in tr._derivative_options["jac_g"].find_functions() if f.name() == "local_jac"
        ).n_instructions()

    y, p = ca.SX.sym("y", 2), ca.SX.sym("p", par.size)
    value = path(y[:1], y[1:], p)
    path_apart = ca.Function("path_apart", [y, p], [value, ca.jacobian(value, y)]).n_instructions()
    # the variance adds its few operations on top of the members, not the members a second time
    assert local_jac_size(path) - local_jac_size(None) < 0.5 * path_apart


def test_psd_part_of_a_2x2_matrix_is_the_eigenvalue_clipped_matrix():
    """(H + |H|) / 2 in closed form equals clipping the negative eigenvalues to 0 (numpy's eigh)."""
    from alcove.science.ocp.derivatives import psd_part_2x2

    H = ca.SX.sym("H", 2, 2)
    fn = ca.Function("psd", [H], [psd_part_2x2(H)])
    rng = np.random.default_rng(7)
    cases = [rng.normal(size=(2, 2)) * 10.0 ** rng.uniform(-3, 3) for _ in range(50)]
    cases += [np.diag([2.0, -3.0]), np.diag([-1.0, -4.0]), np.diag([5.0, 0.0]), np.eye(2), np.zeros((2, 2))]
    for A in cases:
        A = 0.5 * (A + A.T)
        w, V = np.linalg.eigh(A)
        expected = (V * np.maximum(w, 0)) @ V.T
        np.testing.assert_allclose(np.asarray(fn(A)), expected, atol=1e-12 * max(1.0, np.abs(A).max()))


def test_convex_path_hessian_reaches_the_exact_solution():
    """With the path Hessian convexified IPOPT converges to the same KKT point as with the exact
    Hessian, the bound active and held: only the Newton model differs, not the problem."""
    chain = PlanarChain.from_preset(DEFAULT_PRESET)
    lo, hi, t = np.array([0.032]), np.array([0.432]), np.array([30.0])
    phases = (PhaseGrid(0.3, 15, 1e-3, 1e-4, lo, hi, t), PhaseGrid(0.5, 15, 1.0, 1.0, lo, hi, t))
    problem = DiscreteProblem(phases, np.array([0.232]), np.zeros(1), None, np.zeros(1))
    q, qd = ca.SX.sym("q"), ca.SX.sym("qd")
    path = ca.Function("path", [q, qd], [qd**2 * (1 + ca.sin(20 * q) ** 2)])  # nonconvex in (q, qd)
    solutions = []
    for mode in ("exact", "convex"):
        tr = Transcription(chain, problem, aux_contact(DEFAULT_PRESET), path=path, path_upper=0.04, path_hessian=mode)
        x0 = tr.pack(np.full((tr.problem.intervals + 1, 1), 0.232), np.zeros((tr.problem.intervals, 1)))
        res = tr.solve(x0)
        assert res["stats"]["success"], res["stats"]["return_status"]
        path_rows = res["g"][-tr.problem.intervals :]
        assert path_rows.max() <= 0.04 + 1e-8
        assert path_rows.max() > 0.04 - 1e-6  # the bound is active: the constraint matters
        solutions.append((tr, res))
    (exact, at), (convex, _) = solutions
    # the two Newton models differ at the solution (the path term's Hessian is indefinite there)
    _, H_exact = derivatives(exact, at["x"], 1.0, at["lam_g"])
    _, H_convex = derivatives(convex, at["x"], 1.0, at["lam_g"])
    assert np.abs(H_exact - H_convex).max() > 1e-3 * np.abs(H_exact).max()
    solutions = [res for _, res in solutions]
    np.testing.assert_allclose(solutions[1]["x"], solutions[0]["x"], atol=1e-6)
    assert abs(solutions[1]["cost"] - solutions[0]["cost"]) <= 1e-8 * max(1.0, abs(solutions[0]["cost"]))


def test_path_hessian_mode_is_checked():
    chain = PlanarChain.from_preset(DEFAULT_PRESET)
    lo, hi, t = np.array([0.032]), np.array([0.432]), np.array([30.0])
    problem = DiscreteProblem((PhaseGrid(0.3, 4, 1e-3, 1e-4, lo, hi, t),), np.array([0.232]), None, None, None)
    with pytest.raises(ValueError, match="path_hessian"):
        Transcription(chain, problem, None, path=_path_function(1), path_upper=1.0, path_hessian="gauss")


@pytest.mark.parametrize("threads", [2, 3])
def test_grid_maps_on_threads_compute_the_serial_values_bit_for_bit(monkeypatch, threads):
    """The interval functions mapped on several threads (the default on a multi-core machine)
    give exactly the serial map's constraint values, Jacobian and Hessian: each interval is
    computed by the same instructions, only on another thread."""
    from alcove.science import parallel

    chain, problem, contact, path, par, P = _ensemble_problem()
    rng = np.random.default_rng(7)
    n, N = chain.ndof, problem.intervals
    x = np.concatenate([rng.uniform(P.theta_min, P.theta_max, n * (N + 1)), rng.normal(size=n * N)])

    def evaluate(n_threads):
        monkeypatch.setattr(parallel, "grid_threads", lambda: n_threads)
        tr = Transcription(chain, problem, contact, path=path, path_upper=1.0)
        maps = [f.class_name() for f in tr._derivative_options["hess_lag"].find_functions() if "map" in f.name()]
        lam_g = np.random.default_rng(8).normal(size=np.size(tr.lbg))
        g = tr.solver.get_function("nlp_g")(x, par)
        J, H = derivatives(tr, x, 0.7, lam_g, par)
        return maps, np.asarray(g).ravel(), J, H

    serial_maps, *serial = evaluate(1)
    threaded_maps, *threaded = evaluate(threads)
    assert serial_maps and all(name == "Map" for name in serial_maps)
    assert "ThreadMap" in threaded_maps
    for a, b in zip(serial, threaded, strict=True):
        assert np.array_equal(a, b)
