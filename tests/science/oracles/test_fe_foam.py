"""fe-headrest-2d foam law: consistency of stress and tangent, small-strain limit, documented curve."""

import numpy as np
import pytest

from alcove.science.oracles.fe_headrest import FEHeadrestParams
from alcove.science.oracles.fe_headrest.foam import Hyperfoam, foam_response, green_lagrange, svd2

DEFAULT = FEHeadrestParams()
LAW = Hyperfoam(DEFAULT.foam_mu, DEFAULT.foam_alpha, DEFAULT.foam_beta)


def random_deformations(n: int, spread: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    F = np.eye(2) + spread * rng.standard_normal((n, 2, 2))
    F[0] = np.eye(2)  # the reference state (repeated singular values)
    F[1] = np.diag([0.6, 0.6])  # equal compression (repeated singular values)
    F[2] = [[0.5, 0.1], [0.0, 1.0]]  # strong compression plus shear
    return F[np.linalg.det(F) > 0.2]


@pytest.mark.parametrize("law", [LAW, Hyperfoam((20e3,), (5.0,), (0.3,))])
@pytest.mark.parametrize("viscosity_over_dt", [0.0, 4e4])
def test_stress_and_tangent_are_derivatives_of_the_incremental_potential(law, viscosity_over_dt):
    F = random_deformations(40, 0.15)
    E_prev = green_lagrange(random_deformations(40, 0.1, seed=1)[: F.shape[0]])
    res = foam_response(law, F, E_prev, viscosity_over_dt)
    h = 1e-6
    P_fd = np.zeros_like(F)
    A_fd = np.zeros((*F.shape, 2, 2))
    for k in range(2):
        for m in range(2):
            d = np.zeros((2, 2))
            d[k, m] = h
            P_fd[..., k, m] = (
                foam_response(law, F + d, E_prev, viscosity_over_dt, 0).energy
                - foam_response(law, F - d, E_prev, viscosity_over_dt, 0).energy
            ) / (2 * h)
            A_fd[..., k, m] = (
                foam_response(law, F + d, E_prev, viscosity_over_dt, 1).stress
                - foam_response(law, F - d, E_prev, viscosity_over_dt, 1).stress
            ) / (2 * h)
    assert np.abs(P_fd - res.stress).max() <= 1e-6 * np.abs(res.stress).max()
    assert np.abs(A_fd - res.tangent).max() <= 1e-6 * np.abs(res.tangent).max()
    # the tangent of a potential is symmetric (major symmetry)
    np.testing.assert_allclose(
        res.tangent, np.einsum("nijkl->nklij", res.tangent), atol=1e-9 * np.abs(res.tangent).max()
    )


def test_closed_form_svd_reconstructs_F():
    F = random_deformations(200, 0.3)
    cu, su, cv, sv, s1, s2 = svd2(F)
    U = np.stack([np.stack([cu, -su], -1), np.stack([su, cu], -1)], -2)
    V = np.stack([np.stack([cv, -sv], -1), np.stack([sv, cv], -1)], -2)
    S = np.zeros_like(F)
    S[:, 0, 0], S[:, 1, 1] = s1, s2
    np.testing.assert_allclose(U @ S @ np.swapaxes(V, -1, -2), F, atol=1e-13)
    assert np.all(s1 >= s2) and np.all(s2 > 0)


@pytest.mark.parametrize("beta", [0.0, 0.25, 1.0])
def test_small_strain_limit_is_linear_elasticity(beta):
    """Hyperfoam at small strain: shear modulus sum(mu_i), Poisson ratio beta / (1 + 2 beta).

    A laterally confined block (plane strain, l2 = l3 = 1) then has the P-wave modulus
    lambda + 2 mu = 2 mu (1 - nu) / (1 - 2 nu) = 2 mu (1 + beta).
    """
    law = Hyperfoam((30e3, 5e3), (12.0, -2.0), (beta, beta))
    h = 1e-6
    slope = (law.uniaxial_nominal_stress(1 + h) - law.uniaxial_nominal_stress(1 - h)) / (2 * h)
    mu = law.shear_modulus
    nu = law.poisson_ratio
    assert nu == pytest.approx(beta / (1 + 2 * beta))
    assert slope == pytest.approx(2 * mu * (1 - nu) / (1 - 2 * nu), rel=1e-6)
    # simple shear at small strain: P_12 = mu * gamma
    gamma = 1e-6
    F = np.array([[[1.0, gamma], [0.0, 1.0]]])
    assert foam_response(law, F, order=1).stress[0, 0, 1] == pytest.approx(mu * gamma, rel=1e-4)


def test_default_foam_follows_the_documented_headrest_curve():
    """Default = two-term Ogden-Storakers fit of f(e) = A (1 - exp(-E0 e / A)) + B (e / (1 - e))^2
    scaled by 4 (E0 = 240 kPa, A = 24 kPa, B = 16 kPa): within 10 % from 5 % to 80 % strain,
    monotone, with a plateau and densification (docs/fe-oracle.md)."""
    E0, A, B = 240e3, 24e3, 16e3
    e = np.linspace(0.05, 0.8, 31)
    reference = A * (1 - np.exp(-E0 * e / A)) + B * (e / (1 - e)) ** 2
    model = -LAW.uniaxial_nominal_stress(1 - e)
    np.testing.assert_allclose(model, reference, rtol=0.10)
    assert np.all(np.diff(model) > 0)
    tangent = np.diff(model) / np.diff(e)
    assert tangent[len(e) // 3] < 0.2 * tangent[-1]  # plateau, then densification
    assert tangent[len(e) // 3] < 0.2 * 2 * LAW.shear_modulus  # plateau much softer than the initial modulus
