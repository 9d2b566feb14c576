"""Validated parameters of the ``fe-headrest-2d`` oracle (SI units throughout).

Defaults and their physical sources are documented in ``docs/fe-oracle.md``.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from alcove.science.oracles.foam_law import FoamLawParams
from alcove.science.validation import WholeNumber, quantity

CushionHeight = Annotated[float, quantity("height along z_H", "m", ge=-0.3, le=0.4, why="within the cushion")]
MomentPointCoordinate = Annotated[float, quantity("coordinate", "m", ge=-1, le=1, why="within a metre of the head")]


class FEHeadrestParams(FoamLawParams):
    """Plane-strain headrest cushion model: geometry, mesh, foam, contact, stepping, quality gate."""

    # ---- cushion geometry (headrest frame H: front face x = 0, cushion at x < 0) -------------
    cushion_thickness: Annotated[
        float, quantity("foam thickness along -x_H, front face to the tied back face", "m", ge=0.02, le=0.15)
    ] = 0.04
    cushion_height: Annotated[float, quantity("cushion extent along z_H", "m", ge=0.08, le=0.40)] = 0.22
    cushion_bottom: Annotated[
        float,
        quantity("z_H of the cushion's bottom face", "m", ge=-0.30, le=0.0, why="the first-contact point is z_H = 0"),
    ] = -0.10
    out_of_plane_width: Annotated[
        float, quantity("out-of-plane width that turns N/m into N (one slice)", "m", ge=0.02, le=0.40)
    ] = 0.13
    slices: WholeNumber = Field(
        1,
        ge=1,
        le=8,
        description="plane-strain slices through the head summed over its breadth [-], a whole number from 1 to 8 "
        "(1: one slice of out_of_plane_width)",
    )
    head_half_breadth: Annotated[
        float,
        quantity("half breadth of the head (ellipsoidal sections), used when slices > 1", "m", ge=0.04, le=0.12),
    ] = 0.075

    # ---- mesh ---------------------------------------------------------------------------
    element_size_contact: Annotated[
        float,
        quantity(
            "element size in the contact zone and at the front face",
            "m",
            ge=0.0005,
            le=0.02,
            why="at most cushion_thickness / 4",
        ),
    ] = 0.006
    element_size_far: Annotated[
        float,
        quantity(
            "element size toward the back face and the cushion ends",
            "m",
            ge=0.001,
            le=0.05,
            why="at least element_size_contact",
        ),
    ] = 0.015
    contact_zone: tuple[CushionHeight, CushionHeight] = Field(
        (-0.06, 0.07),
        description="z_H range (low, high) meshed with element_size_contact [m], increasing and inside the "
        "cushion's z extent (cushion_bottom to cushion_bottom + cushion_height)",
    )

    # ---- foam: Ogden-Storakers hyperfoam terms + Kelvin-Voigt viscosity -----------------------
    # foam_mu, foam_alpha, foam_beta: the shared foam law (alcove.science.oracles.foam_law)
    viscosity: Annotated[
        float, quantity("Kelvin-Voigt viscosity on the Green-Lagrange strain rate", "Pa s", ge=0.0, le=1e5)
    ] = 300.0

    # ---- contact --------------------------------------------------------------------------
    penalty: Annotated[float, quantity("normal penalty stiffness per unit contact area", "Pa/m", ge=1e6, le=1e12)] = 5e8
    friction: Annotated[float, quantity("Coulomb friction coefficient head/cushion cover", "-", ge=0.0, le=1.5)] = 0.4
    friction_regularization_velocity: Annotated[
        float,
        quantity("slip velocity below which friction is regularized (viscous-like)", "m/s", gt=0.0, le=1.0),
    ] = 0.005

    # ---- output ---------------------------------------------------------------------------
    output_dt: Annotated[
        float,
        quantity("output (and time-step) interval", "s", ge=1e-4, le=0.05, why="0.0025 s gives 401 samples per second"),
    ] = 0.0025
    substeps: WholeNumber = Field(
        1, ge=1, le=16, description="solver steps per output interval [-], a whole number from 1 to 16"
    )
    moment_point: tuple[MomentPointCoordinate, MomentPointCoordinate] = Field(
        (0.0, 0.0), description="moment reference point (x, z) in moment_point_frame [m], each -1 to 1"
    )
    moment_point_frame: Literal["head", "headrest"] = Field(
        "head",
        description="frame of moment_point: 'head' (moves with the head; default the head frame origin) or 'headrest'",
    )

    # ---- solver and quality gate ------------------------------------------------------------
    newton_tolerance: Annotated[
        float, quantity("Newton residual tolerance relative to the contact force", "-", ge=1e-12, le=1e-3)
    ] = 1e-6
    newton_max_iterations: WholeNumber = Field(
        40,
        ge=2,
        le=200,
        description="Newton iterations allowed per step before the run fails [-], a whole number from 2 to 200",
    )
    max_penetration: Annotated[float, quantity("gate: largest allowed penalty penetration", "m", gt=0.0, le=0.01)] = (
        1e-3
    )
    energy_tolerance: Annotated[
        float,
        quantity(
            "gate: allowed negative dissipation relative to the largest energy put in by the head", "-", ge=0.0, le=0.5
        ),
    ] = 0.02
    reaction_tolerance: Annotated[
        float,
        quantity(
            "gate: allowed mismatch of head force and bar reaction relative to the peak force", "-", ge=0.0, le=0.1
        ),
    ] = 1e-3
    max_indentation_fraction: Annotated[
        float,
        quantity(
            "reach: deepest allowed indentation of the undeformed head profile, as a fraction of the cushion thickness",
            "-",
            gt=0.0,
            le=0.9,
        ),
    ] = 0.6

    @model_validator(mode="after")
    def _check_consistency(self) -> FEHeadrestParams:
        if self.element_size_far < self.element_size_contact:
            raise ValueError(
                f"element_size_far: must be at least element_size_contact ({self.element_size_contact:g} m)"
            )
        if self.element_size_contact > 0.25 * self.cushion_thickness:
            raise ValueError(
                "element_size_contact: must be at most cushion_thickness / 4 "
                f"({0.25 * self.cushion_thickness:g} m: at least 4 elements through the foam)"
            )
        lo, hi = self.contact_zone
        top = self.cushion_bottom + self.cushion_height
        if top <= 0.0:
            raise ValueError(
                f"cushion_height: the cushion must extend above the first-contact point z_H = 0 (its top is {top:g} m)"
            )
        if not lo < hi:
            raise ValueError(f"contact_zone.1: must exceed the low end {lo:g} m")
        if not self.cushion_bottom <= lo:
            raise ValueError(f"contact_zone.0: lies below the cushion's bottom face {self.cushion_bottom:g} m")
        if not hi <= top:
            raise ValueError(f"contact_zone.1: lies above the cushion's top face {top:g} m")
        return self
