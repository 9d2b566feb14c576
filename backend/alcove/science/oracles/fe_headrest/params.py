"""Validated parameters of the ``fe-headrest-2d`` oracle (SI units throughout).

Defaults and their physical sources are documented in ``docs/fe-oracle.md``.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from alcove.science.oracles.base import OracleParams


class FEHeadrestParams(OracleParams):
    """Plane-strain headrest cushion model: geometry, mesh, foam, contact, stepping, quality gate."""

    # ---- cushion geometry (headrest frame H: front face x = 0, cushion at x < 0) -------------
    cushion_thickness: float = Field(
        0.04, ge=0.02, le=0.15, description="foam thickness along -x_H, front face to the tied back face [m]"
    )
    cushion_height: float = Field(0.22, ge=0.08, le=0.40, description="cushion extent along z_H [m]")
    cushion_bottom: float = Field(
        -0.10, ge=-0.30, le=0.0, description="z_H of the cushion's bottom face (the first-contact point is z_H = 0) [m]"
    )
    out_of_plane_width: float = Field(
        0.13, ge=0.02, le=0.40, description="out-of-plane width that turns N/m into N (one slice) [m]"
    )
    slices: int = Field(
        1,
        ge=1,
        le=8,
        description="plane-strain slices through the head summed over its breadth (1: one slice of out_of_plane_width)",
    )
    head_half_breadth: float = Field(
        0.075, ge=0.04, le=0.12, description="half breadth of the head (ellipsoidal sections) used when slices > 1 [m]"
    )

    # ---- mesh ---------------------------------------------------------------------------
    element_size_contact: float = Field(
        0.006, ge=0.0005, le=0.02, description="element size in the contact zone and at the front face [m]"
    )
    element_size_far: float = Field(
        0.015, ge=0.001, le=0.05, description="element size toward the back face and the cushion ends [m]"
    )
    contact_zone: tuple[float, float] = Field(
        (-0.06, 0.07), description="z_H range meshed with element_size_contact [m]"
    )

    # ---- foam: Ogden-Storakers hyperfoam terms + Kelvin-Voigt viscosity -----------------------
    foam_mu: tuple[float, ...] = Field(
        (132.0e3, 1.54e3), min_length=1, max_length=3, description="hyperfoam moduli mu_i [Pa]"
    )
    foam_alpha: tuple[float, ...] = Field(
        (16.4, -2.04), min_length=1, max_length=3, description="hyperfoam exponents alpha_i [-]"
    )
    foam_beta: tuple[float, ...] = Field(
        (0.0, 0.0), min_length=1, max_length=3, description="hyperfoam beta_i = nu_i / (1 - 2 nu_i) [-]"
    )
    viscosity: float = Field(
        300.0, ge=0.0, le=1e5, description="Kelvin-Voigt viscosity on the Green-Lagrange strain rate [Pa s]"
    )

    # ---- contact --------------------------------------------------------------------------
    penalty: float = Field(5e8, ge=1e6, le=1e12, description="normal penalty stiffness per unit contact area [Pa/m]")
    friction: float = Field(0.4, ge=0.0, le=1.5, description="Coulomb friction coefficient head/cushion cover [-]")
    friction_regularization_velocity: float = Field(
        0.005, gt=0.0, le=1.0, description="slip velocity below which friction is regularized (viscous-like) [m/s]"
    )

    # ---- output ---------------------------------------------------------------------------
    output_dt: float = Field(
        0.0025,
        ge=1e-4,
        le=0.05,
        description="output (and time-step) interval [s]; 0.0025 s gives 401 samples per second",
    )
    substeps: int = Field(1, ge=1, le=16, description="solver steps per output interval")
    moment_point: tuple[float, float] = Field(
        (0.0, 0.0), description="moment reference point (x, z) [m] in moment_point_frame"
    )
    moment_point_frame: Literal["head", "headrest"] = Field(
        "head",
        description="frame of moment_point: 'head' (moves with the head; default the head frame origin) or 'headrest'",
    )

    # ---- solver and quality gate ------------------------------------------------------------
    newton_tolerance: float = Field(
        1e-6, ge=1e-12, le=1e-3, description="Newton residual tolerance relative to the contact force"
    )
    newton_max_iterations: int = Field(
        40, ge=2, le=200, description="Newton iterations allowed per step before the run fails"
    )
    max_penetration: float = Field(1e-3, gt=0.0, le=0.01, description="gate: largest allowed penalty penetration [m]")
    energy_tolerance: float = Field(
        0.02,
        ge=0.0,
        le=0.5,
        description="gate: allowed negative dissipation relative to the largest energy put in by the head",
    )
    reaction_tolerance: float = Field(
        1e-3,
        ge=0.0,
        le=0.1,
        description="gate: allowed mismatch of head force and bar reaction relative to the peak force",
    )
    max_indentation_fraction: float = Field(
        0.6,
        gt=0.0,
        le=0.9,
        description="reach: deepest allowed indentation of the undeformed head profile, as a fraction of the cushion thickness",
    )

    @model_validator(mode="after")
    def _check_consistency(self) -> FEHeadrestParams:
        n = len(self.foam_mu)
        if len(self.foam_alpha) != n or len(self.foam_beta) != n:
            raise ValueError("foam_mu, foam_alpha and foam_beta must have the same number of terms")
        for i, (mu, a, b) in enumerate(zip(self.foam_mu, self.foam_alpha, self.foam_beta, strict=False)):
            if a == 0.0 or mu <= 0.0:
                # with mu_i > 0 and beta_i >= 0 each term is convex in the logarithmic stretches
                raise ValueError(f"foam term {i}: need mu > 0 and alpha != 0 (stability)")
            if not 0.0 <= b <= 10.0:
                raise ValueError(f"foam_beta[{i}] must lie in [0, 10] (Poisson ratio 0 to ~0.48)")
        if self.element_size_far < self.element_size_contact:
            raise ValueError("element_size_far must be >= element_size_contact")
        if self.element_size_contact > 0.25 * self.cushion_thickness:
            raise ValueError(
                "element_size_contact must be <= cushion_thickness / 4 (at least 4 elements through the foam)"
            )
        lo, hi = self.contact_zone
        top = self.cushion_bottom + self.cushion_height
        if not (self.cushion_bottom <= lo < hi <= top):
            raise ValueError("contact_zone must be an increasing range inside the cushion's z extent")
        if top <= 0.0:
            raise ValueError("the cushion must extend above the first-contact point z_H = 0")
        return self
