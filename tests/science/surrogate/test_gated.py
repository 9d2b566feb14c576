"""The gated output layer's math (the wired architecture: test_gated_model.py): exactly zero with the gap
clearly open, non-negative normal force, C1 (indeed C2) across the blend, CasADi/PyTorch parity,
and the gap recovered from the 19 features is the geometry's signed gap."""

import casadi as ca
import numpy as np
import pytest
import torch

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.geometry import relative_kinematics, signed_gap
from alcove.science.surrogate.features import N_FEATURES, features
from alcove.science.surrogate.gated import (
    GateParams,
    gap_from_features,
    gap_from_features_symbolic,
    gap_from_features_torch,
    gated_wrench_symbolic,
    gated_wrench_torch,
)

GP = GateParams(open_gap=0.002, blend=0.002, force_width=1.0)


def test_gap_from_features_is_the_signed_gap():
    rng = np.random.default_rng(0)
    q, qd = rng.uniform(P.theta_min, P.theta_max, 50), rng.uniform(-3, 3, 50)
    x = features(relative_kinematics(P, q, qd))
    np.testing.assert_allclose(gap_from_features(x, P.profile), signed_gap(P, q), atol=1e-15)
    t = gap_from_features_torch(torch.as_tensor(x), P.profile).numpy()
    np.testing.assert_allclose(t, signed_gap(P, q), atol=1e-15)
    xs = ca.SX.sym("x", N_FEATURES)
    fn = ca.Function("gap", [xs], [gap_from_features_symbolic(xs, P.profile)])
    np.testing.assert_allclose(np.asarray(fn.map(50)(x.T)).ravel(), signed_gap(P, q), atol=1e-15)


def _wrench(u, gap):
    u_t, gap_t = torch.as_tensor(np.asarray(u, float)), torch.as_tensor(np.asarray(gap, float))
    return gated_wrench_torch(u_t, gap_t, GP).numpy()


def test_exactly_zero_when_clearly_open_and_normal_force_pushes_away():
    rng = np.random.default_rng(1)
    u = rng.normal(0, 1e3, (200, 6))
    open_gap = rng.uniform(GP.open_gap, 0.05, 200)
    assert np.all(_wrench(u, open_gap) == 0.0)  # exactly, whatever the networks say
    gap = rng.uniform(-0.01, GP.open_gap, 200)
    w = _wrench(u, gap)
    assert np.all(w[:, 0] >= 0.0)
    closed = gap <= GP.open_gap - GP.blend
    np.testing.assert_allclose(w[closed, 1:], u[closed, 1:], rtol=1e-15)  # gate = 1 in contact


@pytest.mark.parametrize("edge", [GP.open_gap, GP.open_gap - GP.blend])
def test_continuous_with_continuous_first_derivative_across_the_blend(edge):
    """One-sided finite differences of d wrench / d gap at the blend's ends agree as h -> 0
    (the jump in the derivative is below 1e-3 of its scale with h = 1e-7 m)."""
    u = np.array([[3.0, 0.0, -2.0, 0.0, 0.5, 0.0]])
    h = 1e-7
    left = (_wrench(u, [edge]) - _wrench(u, [edge - h])) / h
    right = (_wrench(u, [edge + h]) - _wrench(u, [edge])) / h
    scale = np.abs(u).max() / GP.blend
    assert np.abs(left - right).max() < 1e-3 * scale
    # value continuity
    assert np.abs(_wrench(u, [edge + 1e-12]) - _wrench(u, [edge - 1e-12])).max() < 1e-6
    # the first derivative itself is continuous (zero at both ends of a C1 smoothstep)
    assert np.abs(left).max() < 1e-3 * scale


def test_casadi_and_pytorch_agree():
    rng = np.random.default_rng(2)
    u, gap = rng.normal(0, 50, (100, 6)), rng.uniform(-0.01, 0.006, 100)
    us, gs = ca.SX.sym("u", 6), ca.SX.sym("g")
    fn = ca.Function("gated", [us, gs], [gated_wrench_symbolic(us, gs, GP)])
    sym = np.asarray(fn.map(100)(u.T, gap[None, :])).T
    np.testing.assert_allclose(sym, _wrench(u, gap), rtol=1e-13, atol=1e-12)


def test_bad_gate_parameters_name_the_field():
    with pytest.raises(ValueError, match="blend: must be a positive"):
        GateParams(blend=0.0)
