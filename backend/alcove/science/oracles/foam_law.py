"""The foam law shared by the headrest oracles: one source of truth for its parameters.

Both ``fe-headrest-2d`` (its own plane-strain solver) and ``fe-headrest-3d-ccx`` (CalculiX
``*HYPERFOAM``) take the cushion's Ogden-Storakers hyperfoam from these fields, with the
same defaults and the same checks (docs/fe-oracle.md, "Foam")::

    W = sum_i 2 mu_i / alpha_i^2 [l1^a_i + l2^a_i + l3^a_i - 3 + (J^(-a_i b_i) - 1) / b_i]

which is also the strain energy of Abaqus' and CalculiX' ``*HYPERFOAM`` (there with
nu_i = b_i / (1 + 2 b_i) instead of b_i).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from alcove.science.oracles.base import OracleParams
from alcove.science.spec_checks import quantity

FoamModulus = Annotated[float, quantity("hyperfoam modulus mu_i", "Pa", gt=0, le=1e8, why="foams: 1e3 to 1e6 Pa")]
FoamExponent = Annotated[float, quantity("hyperfoam exponent alpha_i", "-", ge=-50, le=50, why="not 0")]
FoamBeta = Annotated[
    float, quantity("hyperfoam beta_i = nu_i / (1 - 2 nu_i)", "-", ge=0, le=10, why="Poisson ratio 0 to about 0.48")
]

#: The default foam: a two-term fit, 4 x the prototype curve (docs/fe-oracle.md).
DEFAULT_FOAM_MU = (132.0e3, 1.54e3)
DEFAULT_FOAM_ALPHA = (16.4, -2.04)
DEFAULT_FOAM_BETA = (0.0, 0.0)


class FoamLawParams(OracleParams):
    """The cushion's hyperfoam terms (mu_i, alpha_i, beta_i), checked for consistency."""

    foam_mu: tuple[FoamModulus, ...] = Field(
        DEFAULT_FOAM_MU,
        min_length=1,
        max_length=3,
        description="hyperfoam moduli mu_i [Pa], 1 to 3 terms, each above 0 and at most 1e8",
    )
    foam_alpha: tuple[FoamExponent, ...] = Field(
        DEFAULT_FOAM_ALPHA,
        min_length=1,
        max_length=3,
        description="hyperfoam exponents alpha_i [-], one per modulus, each -50 to 50 and not 0",
    )
    foam_beta: tuple[FoamBeta, ...] = Field(
        DEFAULT_FOAM_BETA,
        min_length=1,
        max_length=3,
        description="hyperfoam beta_i = nu_i / (1 - 2 nu_i) [-], one per modulus, each 0 to 10",
    )

    @model_validator(mode="after")
    def _check_foam(self) -> FoamLawParams:
        n = len(self.foam_mu)
        for name in ("foam_alpha", "foam_beta"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name}: needs one term per modulus in foam_mu ({n}), got {len(getattr(self, name))}")
        for i, a in enumerate(self.foam_alpha):
            if a == 0.0:
                # with mu_i > 0 and beta_i >= 0 each term is convex in the logarithmic stretches
                raise ValueError(f"foam_alpha.{i}: must not be 0 (the term would not be stable)")
        return self

    @property
    def foam_terms(self) -> tuple[tuple[float, float, float], ...]:
        """(mu_i, alpha_i, beta_i) of every term."""
        return tuple(zip(self.foam_mu, self.foam_alpha, self.foam_beta, strict=True))


__all__ = [
    "DEFAULT_FOAM_ALPHA",
    "DEFAULT_FOAM_BETA",
    "DEFAULT_FOAM_MU",
    "FoamBeta",
    "FoamExponent",
    "FoamLawParams",
    "FoamModulus",
]
