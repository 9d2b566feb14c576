"""CasADi rebuild: parity with torch in value (1e-10) and gradient, also at alpha = 0."""

import casadi as ca
import numpy as np
import pytest
import torch

from alcove.science.geometry import DEFAULT_PRESET, relative_kinematics, relative_kinematics_symbolic
from alcove.science.surrogate.artifact import casadi_contact_from_artifact
from alcove.science.surrogate.casadi_contact import (
    casadi_contact_function,
    casadi_network_function,
)
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.features import features
from alcove.science.surrogate.mlp import MLP, Standardization, SurrogateModel
from alcove.science.surrogate.training import predict, predict_arrays

P = DEFAULT_PRESET


def random_model(activation: str, gain: float, seed: int = 0) -> SurrogateModel:
    """Untrained nets with large weights, so hidden pre-activations reach |x| > 20
    (where torch.nn.Softplus would switch to the identity)."""
    g = torch.Generator().manual_seed(seed)
    cfg = SurrogateConfig(
        force={"hidden": [6, 6, 4], "activation": activation}, moment={"hidden": [6, 6, 6, 4], "activation": activation}
    )
    nets = [MLP.from_config(cfg.force), MLP.from_config(cfg.moment)]
    for net in nets:
        net.reset_parameters(g)
        with torch.no_grad():
            for p in net.parameters():
                p.mul_(gain)
    rng = np.random.default_rng(seed)
    th = rng.uniform(P.theta_min, P.theta_max, 500)
    x = features(relative_kinematics(P, th, rng.uniform(-2, 2, 500)))
    out = Standardization(rng.normal(size=3), np.array([50.0, 0.0, 3.0]))  # includes a constant output
    return SurrogateModel(
        nets[0], nets[1], Standardization.fit(x), out, Standardization(np.zeros(3), np.ones(3)), cfg, P
    )


def states(n: int = 25, seed: int = 1):
    rng = np.random.default_rng(seed)
    q = np.concatenate([[P.tilt, P.tilt + 1e-9], rng.uniform(P.theta_min, P.theta_max, n)])  # alpha = 0 first
    qd = np.concatenate([[0.0, 0.7], rng.uniform(-3, 3, n)])
    return q, qd


def torch_wrench(model: SurrogateModel):
    def f(x: torch.Tensor) -> torch.Tensor:
        z = (x - torch.as_tensor(model.input_norm.mean)) / torch.as_tensor(model.input_norm.divisor)
        F = model.force_net(z) * torch.as_tensor(model.force_norm.scale) + torch.as_tensor(model.force_norm.mean)
        M = model.moment_net(z) * torch.as_tensor(model.moment_norm.scale) + torch.as_tensor(model.moment_norm.mean)
        return torch.cat([F, M])

    return f


@pytest.fixture(
    params=[("softplus", 1.0), ("softplus", 12.0), ("tanh", 3.0), ("sigmoid", 3.0)], ids=lambda p: f"{p[0]}-x{p[1]:g}"
)
def model(request):
    return random_model(*request.param)


def test_values_match_torch(model):
    fn = casadi_contact_function(model, P)
    assert fn.name_in() == ["q", "qd"] and fn.name_out() == ["wrench"]
    assert fn.size_in(0) == (1, 1) and fn.size_out(0) == (6, 1)
    q, qd = states()
    ref = predict(model, np.arange(q.size, dtype=float), q, qd)
    ref = np.hstack([ref.force, ref.moment])
    got = np.array(fn.map(q.size)(q[None], qd[None])).T
    scale = np.maximum(1.0, np.abs(ref))
    assert np.max(np.abs(got - ref) / scale) < 1e-10
    assert np.all(got[:, 1] == model.force_norm.mean[1])  # constant output reproduced exactly


def test_network_gradient_matches_torch_autograd(model):
    net_fn = casadi_network_function(model)
    x_sym = ca.SX.sym("x", 19)
    jac = ca.Function("J", [x_sym], [ca.jacobian(net_fn(x_sym), x_sym)])
    q, qd = states(8)
    for x in features(relative_kinematics(P, q, qd)):
        expected = torch.autograd.functional.jacobian(torch_wrench(model), torch.as_tensor(x)).numpy()
        got = np.array(jac(x))
        assert np.max(np.abs(got - expected) / np.maximum(1.0, np.abs(expected))) < 1e-10


def test_state_gradient_is_finite_and_matches_finite_differences(model):
    fn = casadi_contact_function(model, P)
    q_s, qd_s = ca.SX.sym("q"), ca.SX.sym("qd")
    w = fn(q_s, qd_s)
    jac = ca.Function("J", [q_s, qd_s], [ca.jacobian(w, ca.vertcat(q_s, qd_s)), ca.jacobian(ca.jacobian(w, q_s), q_s)])
    q, qd = states(6)
    h = 1e-6

    def pred(qq, vv):
        return np.hstack(predict_arrays(model, [qq], [vv])).ravel()

    for a, b in zip(q, qd, strict=False):
        J, H = (np.array(o) for o in jac(a, b))
        assert np.all(np.isfinite(J)) and np.all(np.isfinite(H))  # also at alpha = 0
        fd = np.stack([(pred(a + h, b) - pred(a - h, b)) / (2 * h), (pred(a, b + h) - pred(a, b - h)) / (2 * h)], -1)
        assert np.max(np.abs(J - fd) / np.maximum(1.0, np.abs(fd))) < 1e-5


def test_custom_kinematics_and_artifact_round_trip(tmp_path, trained_smooth):
    from alcove.science.surrogate.artifact import save_artifact

    model = trained_smooth.model
    default = casadi_contact_function(model, P)
    custom = casadi_contact_function(model, P, kinematics=lambda q, qd: relative_kinematics_symbolic(P, q[0], qd[0]))
    save_artifact(model, tmp_path / "m")
    loaded = casadi_contact_from_artifact(tmp_path / "m", P)
    for a, b in zip(*states(5), strict=False):
        ref = np.array(default(a, b))
        assert np.array_equal(np.array(custom(a, b)), ref)
        assert np.array_equal(np.array(loaded(a, b)), ref)
    model.ndof = 2
    try:
        with pytest.raises(ValueError, match=r"^kinematics: the model has 2 degrees of freedom"):
            casadi_contact_function(model, P)
    finally:
        model.ndof = 1
