"""Validated parameters of the ``fe-headrest-3d-ccx`` oracle (SI units throughout).

The cushion (its extent, contact zone, foam law, penalty and friction) is the one of
``fe-headrest-2d``: both inherit :class:`~alcove.science.oracles.cushion.CushionParams`, so that
the two models differ only in what a 3D model adds (docs/fe-oracle.md, "The 3D model").
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field, model_validator

from alcove.science.oracles.cushion import CushionHeight, CushionParams
from alcove.science.spec_checks import WholeNumber, quantity

SemiAxis = Annotated[float, quantity("semi-axis", "m", ge=0.03, le=0.2)]


class CcxHeadrestParams(CushionParams):
    """3D headrest cushion in CalculiX: geometry, mesh, contact, step control, run limits."""

    # ---- cushion block: thickness, height, bottom and contact zone are the shared cushion's;
    # the block adds its width along y_H ---------------------------------------------------
    cushion_width: Annotated[
        float, quantity("cushion extent along y_H (centred on the head)", "m", ge=0.08, le=0.50)
    ] = 0.26

    # ---- head: an ellipsoid; in-plane semi-axes and centre from the preset's profile -----------
    head_half_breadth: Annotated[float, quantity("head semi-axis along y_H (half breadth)", "m", ge=0.04, le=0.12)] = (
        0.075
    )
    head_semi_axes_xz: tuple[SemiAxis, SemiAxis] | None = Field(
        None,
        description="head semi-axes (front-back, up-down) [m], each 0.03 to 0.2; none: the preset's head profile",
    )

    # ---- mesh -------------------------------------------------------------------------------
    element_size_contact: Annotated[
        float,
        quantity(
            "element size in the contact zone and at the front face",
            "m",
            ge=0.002,
            le=0.02,
            why="at most cushion_thickness / 3",
        ),
    ] = 0.008
    element_size_far: Annotated[
        float,
        quantity(
            "element size toward the back face and the block's edges",
            "m",
            ge=0.002,
            le=0.06,
            why="at least element_size_contact",
        ),
    ] = 0.03
    # the fine zone covers where the head can touch the foam: the undeformed head's footprint on
    # the undeformed front face over the preset's whole joint range (|y| <= 31 mm, -42 <= z <= 48 mm)
    # with about one element to spare; the shared cushion's wider zone is the 2D model's
    contact_half_width: Annotated[
        float, quantity("half width along y_H meshed with element_size_contact", "m", ge=0.01, le=0.25)
    ] = 0.04
    contact_zone: tuple[CushionHeight, CushionHeight] = Field(
        (-0.05, 0.06),
        description="z_H range (low, high) meshed with element_size_contact [m], increasing and inside the "
        "cushion's z extent (cushion_bottom to cushion_bottom + cushion_height)",
    )
    element_growth: Annotated[
        float,
        quantity(
            "ratio of neighbouring element sizes along y_H and z_H outside the contact zone",
            "-",
            ge=1.1,
            le=2.5,
            why="the sizes grow from element_size_contact to at most element_size_far",
        ),
    ] = 1.6
    head_element_size: Annotated[
        float, quantity("element size of the head's contact surface", "m", ge=0.002, le=0.03)
    ] = 0.008

    foam_element: Literal["C3D8", "C3D8R", "C3D8I"] = Field(
        "C3D8",
        description="ccx's element of the foam: C3D8 (8 Gauss points), C3D8R (1 Gauss point, hourglass "
        "control) or C3D8I (incompatible modes)",
    )

    # ---- contact -------------------------------------------------------------------------------
    # penalty, friction: the shared cushion's
    contact_formulation: Literal["node-to-surface", "surface-to-surface"] = Field(
        "node-to-surface",
        description="ccx's penalty contact: node-to-surface (default: converges through the first touch and "
        "runs 1.7 x faster here) or surface-to-surface (face-to-face)",
    )
    stick_slope: Annotated[
        float, quantity("tangential penalty stiffness before slip (stick slope)", "Pa/m", ge=1e5, le=1e12)
    ] = 5e7

    # ---- output and step control ----------------------------------------------------------------
    output_dt: Annotated[
        float,
        quantity("output interval", "s", ge=1e-4, le=0.05, why="0.0025 s gives 401 samples per second"),
    ] = 0.0025
    solve_spacing: Annotated[
        float,
        quantity(
            "largest spacing of the outputs ccx computes; the outputs between are interpolated, and every "
            "output is computed around a first touch, a separation, a stop or a reversal of the head and "
            "wherever the error estimate asks for it",
            "s",
            ge=0.0,
            le=0.1,
            why="below 2 x output_dt ccx computes every output (0: always)",
        ),
    ] = 0.04
    interpolation_tolerance: Annotated[
        float,
        quantity(
            "refinement criterion of the computed outputs: largest interpolation error of the force proxy "
            "(undeformed indentation^1.5), relative to its peak",
            "-",
            ge=1e-6,
            le=0.05,
        ),
    ] = 1e-3
    max_increment_fraction: Annotated[
        float,
        quantity("largest increment as a fraction of the computed outputs' largest spacing", "-", gt=0.0, le=1.0),
    ] = 1.0
    min_increment_fraction: Annotated[
        float, quantity("smallest increment (after cutbacks) as a fraction of output_dt", "-", ge=1e-8, le=0.5)
    ] = 1e-4
    residual_floor: Annotated[
        float,
        quantity(
            "largest residual force (any node, any direction) that counts as equilibrium whatever the "
            "displacement correction, once the residual criterion holds (ccx's R_l x q_u)",
            "N",
            ge=1e-7,
            le=1.0,
            why="1e-7 N is ccx's own default; from the residual criterion (0.05 N, late_residual after 9 "
            "iterations) up, the residual alone decides",
        ),
    ] = 0.3
    late_residual: Annotated[
        float,
        quantity(
            "residual criterion from the 10th Newton iteration of an increment on (ccx's R_P x q_u; 0.05 N before)",
            "N",
            ge=0.05,
            le=1.0,
            why="0.2 N is ccx's own R_P",
        ),
    ] = 0.3
    clearance: Annotated[
        float,
        quantity(
            "the solver starts once the undeformed head is within this distance of the cushion",
            "m",
            ge=0.0,
            le=0.05,
            why="before that the force is exactly 0",
        ),
    ] = 0.001
    max_indentation_fraction: Annotated[
        float,
        quantity(
            "deepest allowed indentation of the undeformed head, as a fraction of the thickness", "-", gt=0.0, le=0.9
        ),
    ] = 0.6
    reaction_tolerance: Annotated[
        float,
        quantity(
            "gate: allowed mismatch of the head's wrench and the back face's reaction, relative to the peak",
            "-",
            ge=1e-4,
            le=0.2,
        ),
    ] = 0.01

    # ---- run ---------------------------------------------------------------------------------------
    threads: WholeNumber = Field(1, ge=1, le=64, description="threads of ccx's equation solver [-], 1 to 64")
    timeout_s: Annotated[float, quantity("wall-time limit of one ccx run", "s", gt=0.0, le=86400.0)] = 1800.0
    keep_workdir: bool = Field(False, description="keep the working directory after a successful run")

    @property
    def solve_stride(self) -> int:
        """The largest spacing of the computed outputs in output intervals (1: every output computed)."""
        return max(1, math.floor(self.solve_spacing / self.output_dt + 1e-9))

    @model_validator(mode="after")
    def _check_consistency(self) -> CcxHeadrestParams:
        if self.element_size_far < self.element_size_contact:
            raise ValueError(
                f"element_size_far: must be at least element_size_contact ({self.element_size_contact:g} m)"
            )
        if self.element_size_contact > self.cushion_thickness / 3.0:
            raise ValueError(
                "element_size_contact: must be at most cushion_thickness / 3 "
                f"({self.cushion_thickness / 3.0:g} m: at least 3 elements through the foam)"
            )
        if self.contact_half_width > 0.5 * self.cushion_width:
            raise ValueError(f"contact_half_width: exceeds half the cushion width ({0.5 * self.cushion_width:g} m)")
        return self


__all__ = ["CcxHeadrestParams"]
