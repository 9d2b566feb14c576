"""The headrest cushion both FE oracles share: one source of truth for its extent, the zone
meshed finely, the foam law and the contact's penalty and friction.

``fe-headrest-2d`` (plane strain, its own solver) and ``fe-headrest-3d-ccx`` (CalculiX) take
these fields with the same defaults and the same checks, so that the two models differ only
in what each adds (docs/fe-oracle.md). Headrest frame H: the front face is x = 0, the foam
lies at x < 0, and the first-contact point of the head is z = 0.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, model_validator

from alcove.science.oracles.foam_law import FoamLawParams
from alcove.science.spec_checks import quantity

CushionHeight = Annotated[float, quantity("height along z_H", "m", ge=-0.3, le=0.4, why="within the cushion")]


class CushionParams(FoamLawParams):
    """The cushion's extent in the headrest frame, its finely meshed contact zone, the foam
    law (:class:`FoamLawParams`) and the penalty contact with Coulomb friction."""

    cushion_thickness: Annotated[
        float,
        quantity("foam thickness along -x_H, front face to the back face fixed to the headrest", "m", ge=0.02, le=0.15),
    ] = 0.04
    cushion_height: Annotated[float, quantity("cushion extent along z_H", "m", ge=0.08, le=0.40)] = 0.22
    cushion_bottom: Annotated[
        float,
        quantity("z_H of the cushion's bottom face", "m", ge=-0.30, le=0.0, why="the first-contact point is z_H = 0"),
    ] = -0.10
    contact_zone: tuple[CushionHeight, CushionHeight] = Field(
        (-0.06, 0.07),
        description="z_H range (low, high) meshed with element_size_contact [m], increasing and inside the "
        "cushion's z extent (cushion_bottom to cushion_bottom + cushion_height)",
    )
    penalty: Annotated[
        float, quantity("normal penalty stiffness (contact pressure per unit overclosure)", "Pa/m", ge=1e6, le=1e12)
    ] = 5e8
    friction: Annotated[float, quantity("Coulomb friction coefficient head/cushion cover", "-", ge=0.0, le=1.5)] = 0.4

    @model_validator(mode="after")
    def _check_cushion_extent(self) -> CushionParams:
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


__all__ = ["CushionHeight", "CushionParams"]
