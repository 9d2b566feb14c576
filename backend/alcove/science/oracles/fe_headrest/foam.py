"""Compressible hyperelastic foam (Ogden-Storakers "hyperfoam") with Kelvin-Voigt viscosity, plane strain.

Strain energy per reference volume, principal stretches l1, l2 (in plane), l3 = 1::

    W = sum_i 2 mu_i / alpha_i^2 [l1^a_i + l2^a_i + l3^a_i - 3 + (J^(-a_i b_i) - 1) / b_i]

with b_i = nu_i / (1 - 2 nu_i) (Storakers 1986; the Abaqus HYPERFOAM model); b_i = 0 is
the limit -a_i ln J (no lateral coupling, like LS-DYNA's MAT_057). The initial shear
modulus is sum mu_i. Viscosity: Kelvin-Voigt in the Green-Lagrange strain, S_v = eta dE/dt,
discretised by backward Euler, which is the incremental potential eta / (2 dt) |E - E_n|^2.

Everything is vectorised over quadrature points: deformation gradients have shape
(..., 2, 2). The first Piola stress P = dW/dF and its tangent dP/dF come from the
singular values of F (closed form for 2x2), using the classical formulas for isotropic
energies of the singular values (see e.g. Stomakhin et al. 2012, "Energetically
consistent invertible elasticity"): in the singular frame the tangent couples
(F11, F22) through the Hessian of W and (F12, F21) through the divided differences
(W1 -+ W2) / (s1 -+ s2).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from alcove.science.arrays import FloatArray


class EnergyDerivatives(NamedTuple):
    """Derivatives of W(s1, s2) in the singular values, and the two divided differences."""

    W1: FloatArray
    W2: FloatArray
    W11: FloatArray
    W12: FloatArray
    W22: FloatArray
    Dm: FloatArray  # (W1 - W2) / (s1 - s2)
    Dp: FloatArray  # (W1 + W2) / (s1 + s2)


@dataclass(frozen=True)
class Hyperfoam:
    """Ogden-Storakers hyperfoam terms (mu_i [Pa], alpha_i, beta_i)."""

    mu: tuple[float, ...]
    alpha: tuple[float, ...]
    beta: tuple[float, ...]

    @property
    def shear_modulus(self) -> float:
        return float(sum(self.mu))

    @property
    def poisson_ratio(self) -> float:
        """Small-strain Poisson ratio (exact when all beta_i are equal)."""
        b = float(np.average(self.beta, weights=self.mu))
        return b / (1.0 + 2.0 * b)

    @property
    def youngs_modulus(self) -> float:
        return 2.0 * self.shear_modulus * (1.0 + self.poisson_ratio)

    def _terms(self) -> Iterator[tuple[float, float, float]]:
        """(mu_i, alpha_i, beta_i) of every term."""
        return zip(self.mu, self.alpha, self.beta, strict=True)

    # ---- volumetric part h(J) = (J^(-a b) - 1) / b and its derivatives ------------------
    @staticmethod
    def _h(J: FloatArray, a: float, b: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        if b == 0.0:
            lnJ = np.log(J)
            return -a * lnJ, -a / J, a / J**2
        Jm = J ** (-a * b)
        return (Jm - 1.0) / b, -a * Jm / J, a * (a * b + 1.0) * Jm / J**2

    def energy(self, s1: FloatArray, s2: FloatArray) -> FloatArray:
        J = s1 * s2
        W = np.zeros_like(J)
        for mu, a, b in self._terms():
            W += 2.0 * mu / a**2 * (s1**a + s2**a - 2.0 + self._h(J, a, b)[0])
        return W

    def derivatives(self, s1: FloatArray, s2: FloatArray) -> EnergyDerivatives:
        """W1, W2, W11, W12, W22, (W1 - W2)/(s1 - s2), (W1 + W2)/(s1 + s2)."""
        J = s1 * s2
        W1 = np.zeros_like(J)
        W2, W11, W12, W22, Dm = (np.zeros_like(J) for _ in range(5))
        x = np.log(s1 / s2)
        near = np.abs(x) < 1e-7
        xs = np.where(near, 1.0, x)
        for mu, a, b in self._terms():
            c = 2.0 * mu / a**2
            _, h1, h2 = self._h(J, a, b)
            W1 += c * (a * s1 ** (a - 1) + h1 * s2)
            W2 += c * (a * s2 ** (a - 1) + h1 * s1)
            W11 += c * (a * (a - 1) * s1 ** (a - 2) + h2 * s2**2)
            W22 += c * (a * (a - 1) * s2 ** (a - 2) + h2 * s1**2)
            W12 += c * (h2 * J + h1)
            # divided difference (s1^m - s2^m) / (s1 - s2), m = a - 1, stable near s1 = s2
            m = a - 1.0
            ratio = np.where(near, m, np.expm1(m * xs) / np.expm1(xs))
            Dm += c * (a * s2 ** (m - 1.0) * ratio - h1)
        Dp = (W1 + W2) / (s1 + s2)
        return EnergyDerivatives(W1, W2, W11, W12, W22, Dm, Dp)

    def uniaxial_nominal_stress(self, stretch: FloatArray) -> FloatArray:
        """Nominal stress of a laterally unstrained block (l2 = l3 = 1) at stretch l1 [Pa].

        With beta = 0 this is also the unconfined uniaxial curve: the lateral stress
        vanishes at l2 = 1, so the block does not bulge.
        """
        s1 = np.asarray(stretch, float)
        return self.derivatives(s1, np.ones_like(s1)).W1


def singular_values2(F: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Singular values s1 >= s2 > 0 of 2x2 matrices with det > 0, from |F|^2 and det F."""
    a, b, c, d = F[..., 0, 0], F[..., 0, 1], F[..., 1, 0], F[..., 1, 1]
    J = a * d - b * c
    norm2 = a * a + b * b + c * c + d * d
    plus = np.sqrt(norm2 + 2.0 * J)
    minus = np.sqrt(np.maximum(norm2 - 2.0 * J, 0.0))
    return 0.5 * (plus + minus), 0.5 * (plus - minus)


def svd2(F: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Closed-form SVD of 2x2 matrices with det > 0: F = U diag(s1, s2) V^T, U and V rotations.

    Returns (cos, sin) of the angle of U, (cos, sin) of the angle of V, s1 and s2.
    Polar decomposition F = R S (R a rotation), then the eigenframe of the symmetric S.
    """
    a, b, c, d = F[..., 0, 0], F[..., 0, 1], F[..., 1, 0], F[..., 1, 1]
    ang_r = np.arctan2(c - b, a + d)
    cr, sr = np.cos(ang_r), np.sin(ang_r)
    s00 = cr * a + sr * c  # S = R^T F
    s01 = cr * b + sr * d
    s11 = -sr * b + cr * d
    ang_q = 0.5 * np.arctan2(2.0 * s01, s00 - s11)
    mean = 0.5 * (s00 + s11)
    rad = np.hypot(0.5 * (s00 - s11), s01)
    ang_u = ang_r + ang_q
    return np.cos(ang_u), np.sin(ang_u), np.cos(ang_q), np.sin(ang_q), mean + rad, mean - rad


@dataclass
class FoamResponse:
    energy: FloatArray  # (...,) per reference volume, elastic + viscous incremental potential
    elastic: FloatArray  # (...,) elastic strain energy alone
    stress: FloatArray | None  # (..., 2, 2) first Piola
    tangent: FloatArray | None  # (..., 2, 2, 2, 2)
    valid: bool  # False if an element is inverted (J <= 0)


def foam_response(
    law: Hyperfoam,
    F: FloatArray,
    E_prev: FloatArray | None = None,
    viscosity_over_dt: float = 0.0,
    order: int = 2,
) -> FoamResponse:
    """Incremental potential, first Piola stress and tangent at deformation gradients F.

    ``order``: 0 energy only, 1 energy and stress, 2 energy, stress and tangent.
    """
    J = F[..., 0, 0] * F[..., 1, 1] - F[..., 0, 1] * F[..., 1, 0]
    if np.any(J <= 1e-8):
        return FoamResponse(np.full(J.shape, np.inf), np.full(J.shape, np.inf), None, None, False)
    # Kelvin-Voigt viscosity: strain increment of the step and its incremental potential
    dE: FloatArray | None = None
    visc_energy: FloatArray | float = 0.0
    if viscosity_over_dt > 0.0 and E_prev is not None:
        dE = green_lagrange(F) - E_prev
        visc_energy = 0.5 * viscosity_over_dt * (dE[..., 0, 0] ** 2 + dE[..., 1, 1] ** 2 + 2.0 * dE[..., 0, 1] ** 2)
    if order == 0:
        s1, s2 = singular_values2(F)
        elastic = law.energy(s1, s2)
        return FoamResponse(elastic + visc_energy if dE is not None else elastic, elastic, None, None, True)
    cu, su, cv, sv, s1, s2 = svd2(F)
    elastic = law.energy(s1, s2)
    energy = elastic + visc_energy if dE is not None else elastic
    W1, W2, W11, W12, W22, Dm, Dp = law.derivatives(s1, s2)
    # frame matrices M_ab = u_a (x) v_b flattened (00, 01, 10, 11), u_0 = (cu, su), u_1 = (-su, cu)
    Mmat = np.empty((*J.shape, 4, 4))  # rows: M_00, M_11, M_01, M_10
    u = ((cu, su), (-su, cu))
    v = ((cv, sv), (-sv, cv))
    for row, (a, b) in enumerate(((0, 0), (1, 1), (0, 1), (1, 0))):
        for col, (i, j) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
            Mmat[..., row, col] = u[a][i] * v[b][j]
    P = (W1[..., None] * Mmat[..., 0, :] + W2[..., None] * Mmat[..., 1, :]).reshape(F.shape)
    S_v = None if dE is None else viscosity_over_dt * dE
    if S_v is not None:
        P = P + _matmul2(F, S_v)
    if order == 1:
        return FoamResponse(energy, elastic, P, None, True)
    # tangent = M^T C M with C the singular-frame tangent on (00, 11, 01, 10)
    C = np.zeros((*J.shape, 4, 4))
    C[..., 0, 0] = W11
    C[..., 0, 1] = W12
    C[..., 1, 0] = W12
    C[..., 1, 1] = W22
    C[..., 2, 2] = C[..., 3, 3] = 0.5 * (Dm + Dp)
    C[..., 2, 3] = C[..., 3, 2] = 0.5 * (Dm - Dp)
    A = (np.swapaxes(Mmat, -1, -2) @ C @ Mmat).reshape((*F.shape, 2, 2))
    if S_v is not None:
        # Kelvin-Voigt tangent: delta_ik S_JL + eta/(2 dt) (F_iL F_kJ + (F F^T)_ik delta_JL)
        h = 0.5 * viscosity_over_dt
        hG = h * _matmul2(F, np.swapaxes(F, -1, -2))
        A += h * F[..., :, None, None, :] * F.swapaxes(-1, -2)[..., None, :, :, None]
        for i in range(2):
            A[..., i, :, i, :] += S_v
            A[..., :, i, :, i] += hG
    return FoamResponse(energy, elastic, P, A, True)


def _matmul2(X: FloatArray, Y: FloatArray) -> FloatArray:
    """Product of stacks of 2x2 matrices, written out (faster than batched matmul)."""
    Z = np.empty(np.broadcast_shapes(X.shape, Y.shape))
    for i in range(2):
        for j in range(2):
            Z[..., i, j] = X[..., i, 0] * Y[..., 0, j] + X[..., i, 1] * Y[..., 1, j]
    return Z


def green_lagrange(F: FloatArray) -> FloatArray:
    """E = (F^T F - I) / 2 for (..., 2, 2) arrays."""
    a, b, c, d = F[..., 0, 0], F[..., 0, 1], F[..., 1, 0], F[..., 1, 1]
    E = np.empty(F.shape)
    E[..., 0, 0] = 0.5 * (a * a + c * c - 1.0)
    E[..., 1, 1] = 0.5 * (b * b + d * d - 1.0)
    E[..., 0, 1] = E[..., 1, 0] = 0.5 * (a * b + c * d)
    return E
