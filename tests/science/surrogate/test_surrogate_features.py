"""The paper's 19 features: hand-computed cases, NumPy/CasADi agreement, smooth alpha^2."""

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from alcove.science.geometry import (
    DEFAULT_PRESET,
    RelativeKinematics,
    relative_kinematics,
    relative_kinematics_symbolic,
    rot3_from_tilt,
)
from alcove.science.surrogate.features import (
    FEATURE_NAMES,
    N_FEATURES,
    alpha_squared,
    alpha_squared_symbolic,
    features,
    features_symbolic,
)


def kin(r, v, T, w):
    return RelativeKinematics(np.atleast_2d(r), np.atleast_2d(v), np.asarray(T).reshape(-1, 3, 3), np.atleast_2d(w))


def test_layout_is_the_papers():
    assert N_FEATURES == 19
    assert FEATURE_NAMES[15:] == ("r_sq", "v_sq", "alpha_sq", "omega_sq")


def test_pure_translation():
    r, v = np.array([0.01, -0.02, 0.03]), np.array([0.5, 0.0, -1.5])
    x = features(kin(r, v, np.eye(3), np.zeros(3)))[0]
    expected = [*r, *v, 1, 0, 0, 0, 1, 0, 0, 0, 0, 0.01**2 + 0.02**2 + 0.03**2, 0.25 + 2.25, 0.0, 0.0]
    np.testing.assert_allclose(x, expected, rtol=0, atol=1e-15)


def test_pure_planar_rotation():
    phi, w = 0.4, -1.2
    x = features(kin(np.zeros(3), np.zeros(3), rot3_from_tilt(phi), [0, w, 0]))[0]
    c, s = np.cos(phi), np.sin(phi)
    # R_y(-phi): first column (c, 0, s), second column (0, 1, 0)
    expected = [0, 0, 0, 0, 0, 0, c, 0, s, 0, 1, 0, 0, w, 0, 0, 0, phi**2, w**2]
    np.testing.assert_allclose(x, expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-3, 0.0099, 0.0101, 0.7, 2.0, 3.0, np.pi - 1e-6])
def test_alpha_squared_is_the_rotation_angle_squared(angle):
    axis = np.array([1.0, 2.0, -3.0]) / np.sqrt(14.0)
    T = Rotation.from_rotvec(angle * axis).as_matrix()
    assert alpha_squared(T[None])[0] == pytest.approx(angle**2, rel=1e-12, abs=1e-24)
    # the arccos definition of the paper, where it is well conditioned
    if 0.1 < angle < 3.0:
        assert alpha_squared(T[None])[0] == pytest.approx(np.arccos((np.trace(T) - 1) / 2) ** 2, rel=1e-12)


def test_combined_motion_in_3d():
    rng = np.random.default_rng(3)
    rot = Rotation.from_rotvec([0.2, -0.5, 0.1])
    r, v, w = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    x = features(kin(r, v, rot.as_matrix(), w))[0]
    T = rot.as_matrix()
    np.testing.assert_allclose(x[:15], np.concatenate([r, v, T[:, 0], T[:, 1], w]), atol=1e-15)
    np.testing.assert_allclose(x[15:], [r @ r, v @ v, rot.magnitude() ** 2, w @ w], rtol=1e-13)


def test_batches_and_the_preset():
    p = DEFAULT_PRESET
    th = np.array([p.tilt, 0.1, 0.4])
    x = features(relative_kinematics(p, th, np.array([0.0, 1.0, -2.0])))
    assert x.shape == (3, 19)
    np.testing.assert_allclose(x[:, 17], (th - p.tilt) ** 2, atol=1e-16)  # alpha = relative tilt
    np.testing.assert_allclose(x[:, 18], [0.0, 1.0, 4.0])
    assert np.all(x[:, [1, 4, 7, 9, 11, 12, 14]] == 0)  # planar: y components, T_10, T_01, T_21 vanish
    assert np.all(x[:, 10] == 1)


def test_symbolic_features_equal_numpy_on_random_3d_kinematics():
    rng = np.random.default_rng(0)
    r, v, w = (ca.SX.sym(n, 3) for n in "rvw")
    T = ca.SX.sym("T", 3, 3)
    f = ca.Function("f", [r, v, T, w], [features_symbolic(r, v, T, w)])
    for rot in Rotation.random(20, random_state=1):
        rr, vv, ww = rng.normal(size=(3, 3))
        num = features(kin(rr, vv, rot.as_matrix(), ww))[0]
        np.testing.assert_allclose(np.array(f(rr, vv, rot.as_matrix(), ww)).ravel(), num, rtol=1e-13, atol=1e-15)


def test_alpha_squared_has_finite_derivatives_at_zero():
    # planar: alpha^2 = (theta - tilt)^2, so d/dtheta = 2 (theta - tilt) and d2/dtheta2 = 2, also at alpha = 0
    theta = ca.SX.sym("theta")
    _, _, T, _ = relative_kinematics_symbolic(DEFAULT_PRESET, theta, 0.0)
    a2 = alpha_squared_symbolic(T)
    f = ca.Function("f", [theta], [a2, ca.gradient(a2, theta), ca.hessian(a2, theta)[0]])
    tilt = DEFAULT_PRESET.tilt
    for th in [tilt, tilt + 1e-7, tilt - 0.005, tilt + 0.2]:
        val, grad, hess = (float(o) for o in f(th))
        assert np.isfinite([val, grad, hess]).all()
        assert val == pytest.approx((th - tilt) ** 2, rel=1e-12, abs=1e-28)
        assert grad == pytest.approx(2 * (th - tilt), rel=1e-10, abs=1e-20)
        assert hess == pytest.approx(2.0, rel=1e-9)
    # 3D: alpha^2 of exp(hat(u)) is |u|^2: gradient 2u and Hessian 2I, also at u = 0
    u = ca.SX.sym("u", 3)
    K = ca.skew(u)
    th2 = ca.sumsqr(u)
    # Rodrigues with series-safe coefficients for the test point u = 0
    T3 = ca.SX.eye(3) + K + 0.5 * K @ K - (1.0 / 6.0) * th2 * K - (1.0 / 24.0) * th2 * K @ K
    a2 = alpha_squared_symbolic(T3)
    g = ca.Function("g", [u], [ca.gradient(a2, u), ca.hessian(a2, u)[0]])
    grad, hess = (np.array(o) for o in g(np.zeros(3)))
    np.testing.assert_allclose(grad.ravel(), 0.0, atol=1e-15)
    np.testing.assert_allclose(hess, 2 * np.eye(3), atol=1e-12)
