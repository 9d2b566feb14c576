"""The ``gated`` architecture wired end to end: a trained gated model predicts exactly zero where
the gap is clearly open, a non-negative normal force, is C1 across the gate (finite differences
of the whole model around both ends of the blend), and its CasADi rebuilds match PyTorch in
value and gradient (float64); vectorised training equals training each member alone; the
artifact records the architecture and loads back (TorchScript included)."""

from __future__ import annotations

import json
import warnings

import casadi as ca
import numpy as np
import pytest
import torch
from scipy.optimize import brentq

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import relative_kinematics, signed_gap
from alcove.science.surrogate.artifact import ArtifactError, load_artifact, save_artifact
from alcove.science.surrogate.casadi_contact import (
    casadi_contact_function,
    casadi_contact_std_function,
    casadi_network_function,
    surrogate_contact,
    surrogate_contact_std,
)
from alcove.science.surrogate.config import SurrogateConfig, SurrogateConfigError
from alcove.science.surrogate.features import N_FEATURES, features
from alcove.science.surrogate.gated import (
    DEFAULT_GATE,
    gap_from_features_torch,
    gate_torch,
    gated_net_output_torch,
)
from alcove.science.surrogate.training import predict_ensemble, train_surrogate

GATED = SurrogateConfig(architecture="gated", max_epochs=40, batch_size=256, ensemble_size=1, dtype="float64")
VALUE_TOL = 1e-10  # |casadi - torch| / max(1, |torch|), float64 on both sides


def q_at_gap(gap: float) -> float:
    """The head angle at which the signed gap equals ``gap`` (the gap falls monotonically with theta here)."""
    return float(brentq(lambda th: signed_gap(P, th)[0] - gap, P.theta_min, P.theta_max, xtol=1e-15))


Q_OPEN = q_at_gap(DEFAULT_GATE.open_gap)  # the gate closes completely beyond this angle...
Q_SHUT = q_at_gap(DEFAULT_GATE.open_gap - DEFAULT_GATE.blend)  # ... and is fully open from this one


@pytest.fixture(scope="module", params=[1, 3], ids=["K=1", "K=3"])
def gated(request, contact_pool):
    return train_surrogate(contact_pool, GATED.model_copy(update={"ensemble_size": request.param}), seed=0).model


def test_the_config_names_the_architecture():
    assert SurrogateConfig().architecture == "paper"
    assert SurrogateConfig.parse({"architecture": "gated"}).architecture == "gated"
    with pytest.raises(SurrogateConfigError) as info:
        SurrogateConfig.parse({"architecture": "contact"})
    assert info.value.field == "architecture" and "'paper' or 'gated'" in info.value.reason


def test_exactly_zero_where_the_gap_is_clearly_open(gated):
    rng = np.random.default_rng(0)
    q = np.concatenate([[Q_OPEN - 1e-10], rng.uniform(P.theta_min, Q_OPEN, 200)])  # up to 1e-11 m from the edge
    qd = rng.uniform(-3, 3, q.size)
    assert np.all(signed_gap(P, q) >= DEFAULT_GATE.open_gap)
    p = predict_ensemble(gated, q, qd)
    for a in (p.force, p.moment, p.force_std, p.moment_std):
        assert np.all(a == 0.0)  # exactly, whatever the networks say
    fn, std = casadi_contact_function(gated, P), casadi_contact_std_function(gated, P)
    par, p_values = surrogate_contact(gated, P)
    for i in range(0, q.size, 20):
        assert np.all(np.asarray(fn(q[i], qd[i])) == 0.0)
        assert np.all(np.asarray(std(q[i], qd[i])[1]) == 0.0)
        assert np.all(np.asarray(par(q[i], qd[i], p_values)) == 0.0)
    # ... while the model does predict contact where the data has it
    inside = predict_ensemble(gated, np.array([P.theta_max]), np.array([0.0]))
    assert inside.force[0, 0] > 10.0


def test_the_normal_force_is_never_negative(gated):
    """fx >= 0 along the outward normal x_H: the force pushes the head away, everywhere in the joint range."""
    rng = np.random.default_rng(1)
    q, qd = rng.uniform(P.theta_min, P.theta_max, 2000), rng.uniform(-4, 4, 2000)
    p = predict_ensemble(gated, q, qd)
    assert np.all(p.force[:, 0] >= 0.0)
    fn = casadi_contact_function(gated, P).map(q.size)
    assert np.all(np.asarray(fn(q[None, :], qd[None, :]))[0] >= 0.0)


@pytest.mark.parametrize("edge", ["open", "shut"])
def test_continuous_with_a_continuous_first_derivative_across_the_gate(gated, edge):
    """Around each end of the blend: the wrench is continuous, and the one-sided finite
    differences d wrench / d q from the left and from the right agree (C1), as do CasADi's exact
    derivatives just inside and outside. A gate that is only C0 (a linear ramp) jumps in its
    derivative by |u| / blend * dgap/dq, ~50 % of the scale used here."""
    q0 = Q_OPEN if edge == "open" else Q_SHUT
    qd = 0.4

    def w(q: float) -> np.ndarray:
        p = predict_ensemble(gated, np.array([q]), np.array([qd]))
        return np.concatenate([p.force[0], p.moment[0]])

    h = 1e-7
    left, right = (w(q0) - w(q0 - h)) / h, (w(q0 + h) - w(q0)) / h
    # the derivative's scale across the blend: the largest central difference in it
    grid = np.linspace(Q_OPEN, Q_SHUT, 41)
    scale = max(1.0, max(np.abs((w(g + 1e-6) - w(g - 1e-6)) / 2e-6).max() for g in grid))
    assert np.abs(left - right).max() <= 1e-4 * scale  # threshold: O(h w'') << the jump of a C0 gate
    assert np.abs(w(q0 + 1e-12) - w(q0 - 1e-12)).max() <= 1e-9 * scale
    fn = casadi_contact_function(gated, P)
    qs, qds = ca.SX.sym("q"), ca.SX.sym("qd")
    jac = ca.Function("dwrench", [qs, qds], [ca.jacobian(fn(qs, qds), qs)])
    before, after = (np.asarray(jac(q0 + s, qd)).ravel() for s in (-1e-9, 1e-9))
    assert np.abs(before - after).max() <= 1e-4 * scale
    np.testing.assert_allclose(0.5 * (before + after), 0.5 * (left + right), atol=1e-4 * scale)
    if edge == "open":  # the derivative itself vanishes where the gate closes
        assert np.abs(left).max() <= 1e-4 * scale


def _states(n=60, seed=2):
    rng = np.random.default_rng(seed)
    q = np.concatenate([[P.tilt, Q_OPEN + 1e-4, 0.5 * (Q_OPEN + Q_SHUT)], rng.uniform(P.theta_min, P.theta_max, n)])
    qd = np.concatenate([[0.0, 0.3, -0.5], rng.uniform(-3, 3, n)])
    return q, qd


def _torch_wrench(model):
    """The gated ensemble mean from raw features, written with torch autograd (float64)."""

    def f(x: torch.Tensor) -> torch.Tensor:
        g = gate_torch(gap_from_features_torch(x, P.profile), DEFAULT_GATE)
        outs = []
        for m in model.members:
            z = (x - torch.as_tensor(m.input_norm.mean)) / torch.as_tensor(m.input_norm.divisor)
            parts = []
            for net in ("force", "moment"):
                norm = getattr(m, f"{net}_norm")
                u = getattr(m, f"{net}_net")(z) * torch.as_tensor(norm.scale) + torch.as_tensor(norm.mean)
                parts.append(gated_net_output_torch(net, u, g, DEFAULT_GATE, axis=0))
            outs.append(torch.cat(parts))
        return torch.stack(outs).mean(0)

    return f


def test_torch_and_casadi_agree_in_value_and_gradient(gated):
    q, qd = _states()
    x = features(relative_kinematics(P, q, qd))
    p = predict_ensemble(gated, q, qd)
    want = np.hstack([p.force, p.moment])
    fn = casadi_contact_function(gated, P)
    got = np.asarray(fn.map(q.size)(q[None, :], qd[None, :])).T
    assert np.max(np.abs(got - want) / np.maximum(1.0, np.abs(want))) <= VALUE_TOL
    par, p_values = surrogate_contact(gated, P)  # the OCP's parametric form
    got_p = np.asarray(par.map(q.size)(q[None, :], qd[None, :], np.repeat(p_values[:, None], q.size, 1))).T
    assert np.max(np.abs(got_p - want) / np.maximum(1.0, np.abs(want))) <= VALUE_TOL
    if gated.ensemble_size > 1:
        std_fn, _ = surrogate_contact_std(gated, P)
        std = np.asarray(std_fn.map(q.size)(q[None, :], qd[None, :], np.repeat(p_values[:, None], q.size, 1))[0]).T
        want_std = np.hstack([p.force_std, p.moment_std])
        assert np.max(np.abs(std - want_std) / np.maximum(1.0, want_std)) <= VALUE_TOL
    # gradient w.r.t. the 19 features: torch autograd against CasADi's AD
    net_fn = casadi_network_function(gated)
    xs = ca.SX.sym("x", N_FEATURES)
    jac_fn = ca.Function("jac_features", [xs], [ca.jacobian(net_fn(xs), xs)])
    f = _torch_wrench(gated)
    for row in x:
        xt = torch.as_tensor(row).requires_grad_()
        jt = torch.autograd.functional.jacobian(f, xt).numpy()
        jc = np.asarray(jac_fn(row))
        np.testing.assert_allclose(jc, jt, rtol=1e-9, atol=1e-9 * max(1.0, np.abs(jt).max()))
        np.testing.assert_allclose(np.asarray(net_fn(row)).ravel(), f(xt).detach().numpy(), rtol=1e-12, atol=1e-10)


def test_gradient_in_the_state_matches_finite_differences(gated):
    """CasADi's d wrench / d (q, qd) against central differences of the PyTorch prediction (step 1e-6)."""
    fn = casadi_contact_function(gated, P)
    qs, qds = ca.SX.sym("q"), ca.SX.sym("qd")
    jac = ca.Function("dwrench", [qs, qds], [ca.jacobian(fn(qs, qds), ca.vertcat(qs, qds))])
    q, qd = _states(20, seed=3)

    def w(a, b):
        p = predict_ensemble(gated, np.array([a]), np.array([b]))
        return np.concatenate([p.force[0], p.moment[0]])

    h = 1e-6
    for a, b in zip(q, qd, strict=True):
        fd = np.stack([(w(a + h, b) - w(a - h, b)) / (2 * h), (w(a, b + h) - w(a, b - h)) / (2 * h)], 1)
        ad = np.asarray(jac(a, b))
        # threshold: central differences err by O(h^2 w''') plus rounding eps |w| / h
        np.testing.assert_allclose(ad, fd, rtol=1e-5, atol=1e-5 * max(1.0, np.abs(fd).max()))


def test_vectorised_gated_training_equals_each_member_alone(contact_pool):
    cfg = GATED.model_copy(update={"ensemble_size": 2, "max_epochs": 15, "learning_rate": 0.05})
    seeds = [5, 6]
    ensemble = train_surrogate(contact_pool, cfg, seed=0, member_seeds=seeds).model
    for member, s in zip(ensemble.members, seeds, strict=True):
        alone = train_surrogate(contact_pool, cfg.model_copy(update={"ensemble_size": 1}), seed=s).model
        for net in ("force_net", "moment_net"):
            got, want = getattr(member, net).state_dict(), getattr(alone, net).state_dict()
            for name in got:  # threshold: float64 rounding of batched vs single matrix products
                torch.testing.assert_close(got[name], want[name], rtol=1e-9, atol=1e-11)


def test_the_artifact_records_the_architecture_and_loads_back(gated, tmp_path):
    save_artifact(gated, tmp_path / "m", exports=False)
    doc = json.loads((tmp_path / "m" / "surrogate.json").read_text())
    assert doc["config"]["architecture"] == "gated" and doc["architecture"]["name"] == "gated"
    assert doc["architecture"]["gate"] == {"open_gap": 0.002, "blend": 0.002, "force_width": 1.0}
    loaded = load_artifact(tmp_path / "m")
    assert loaded.architecture == "gated" and loaded.ensemble_size == gated.ensemble_size
    q, qd = _states()
    a, b = predict_ensemble(gated, q, qd), predict_ensemble(loaded, q, qd)
    np.testing.assert_array_equal(a.force, b.force)
    np.testing.assert_array_equal(a.moment, b.moment)
    x = torch.as_tensor(features(relative_kinematics(P, q, qd)))
    for net in ("force", "moment"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # TorchScript is the artifact's contract
            scripted = torch.jit.load(str(tmp_path / "m" / f"{net}.pt"))
        with torch.no_grad():
            out = scripted(x).numpy()
        np.testing.assert_allclose(out, getattr(a, net), rtol=1e-12, atol=1e-12)
    doc["architecture"] = {"name": "paper"}  # a document whose record contradicts its config
    (tmp_path / "m" / "surrogate.json").write_text(json.dumps(doc))
    with pytest.raises(ArtifactError, match=r"^architecture: "):
        load_artifact(tmp_path / "m")


def test_a_paper_warm_start_does_not_seed_a_gated_model(contact_pool):
    paper = train_surrogate(contact_pool, GATED.model_copy(update={"architecture": "paper", "max_epochs": 3}), seed=0)
    gated = train_surrogate(contact_pool, GATED.model_copy(update={"max_epochs": 3}), seed=0, warm_start=paper.model)
    assert gated.model.lineage["warm_start"] == dict.fromkeys(("force", "moment"), "cold: architecture paper -> gated")


def test_the_gate_is_configurable_and_validated(contact_pool, tmp_path):
    """A 5 mm open gap and 3 mm blend: exactly zero beyond 5 mm (in torch, CasADi and the loaded
    artifact), not forced to zero between 2 and 5 mm; bad values name their field."""
    cfg = GATED.model_copy(
        update={"max_epochs": 5, "gate": SurrogateConfig.parse({"gate": {"open_gap": 0.005, "blend": 0.003}}).gate}
    )
    model = train_surrogate(contact_pool, cfg, seed=0).model
    assert model.gate is not None and (model.gate.params.open_gap, model.gate.params.blend) == (0.005, 0.003)
    q_open = q_at_gap(0.005)
    q = np.linspace(P.theta_min, q_open - 1e-10, 50)
    assert np.all(signed_gap(P, q) >= 0.005)
    p = predict_ensemble(model, q, np.zeros_like(q))
    assert np.all(p.force == 0.0) and np.all(p.moment == 0.0)
    fn, values = surrogate_contact(model, P)
    assert all(np.all(np.asarray(fn(qi, 0.0, values)) == 0.0) for qi in q[::10])
    q_band = np.array([q_at_gap(0.003)])  # inside the blend: the gate is strictly between 0 and 1
    x_band = torch.as_tensor(features(relative_kinematics(P, q_band, q_band * 0)))
    g = gate_torch(gap_from_features_torch(x_band, P.profile), model.gate.params)
    assert 0.0 < float(g[0]) < 1.0
    save_artifact(model, tmp_path / "g", exports=False)
    loaded = load_artifact(tmp_path / "g")
    assert loaded.gate is not None and loaded.gate.params == model.gate.params
    for field, value in (("open_gap", 0.0), ("blend", 0.1), ("force_width", -1.0)):
        with pytest.raises(SurrogateConfigError) as info:
            SurrogateConfig.parse({"gate": {field: value}})
        assert info.value.field == f"gate.{field}"
