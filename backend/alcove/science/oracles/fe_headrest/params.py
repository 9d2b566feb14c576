"""Validated parameters of the ``fe-headrest-2d`` oracle (SI units throughout).

Defaults and their physical sources are documented in ``docs/fe-oracle.md``.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from alcove.science.oracles.cushion import CushionParams
from alcove.science.spec_checks import WholeNumber, quantity

MomentPointCoordinate = Annotated[float, quantity("coordinate", "m", ge=-1, le=1, why="within a metre of the head")]


class FEHeadrestParams(CushionParams):
    """Plane-strain headrest cushion model: geometry, mesh, foam, contact, stepping, quality gate.

    The cushion's extent, contact zone, foam law, penalty and friction are the shared
    :class:`~alcove.science.oracles.cushion.CushionParams`."""

    # ---- plane strain: out-of-plane extent ----------------------------------------------------
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

    # ---- foam: Ogden-Storakers hyperfoam terms + Kelvin-Voigt viscosity -----------------------
    # foam_mu, foam_alpha, foam_beta: the shared foam law (alcove.science.oracles.foam_law)
    viscosity: Annotated[
        float, quantity("Kelvin-Voigt viscosity on the Green-Lagrange strain rate", "Pa s", ge=0.0, le=1e5)
    ] = 300.0

    # ---- contact --------------------------------------------------------------------------
    # penalty, friction: the shared cushion (alcove.science.oracles.cushion)
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
        return self
