"""The built-in oracle types: where each one's implementation lives, imported on first use.

The table names modules and classes instead of importing them, so that the FE oracle's
dependencies (scikit-fem) load only when that type is used and a type whose module is
missing does not break the others. :mod:`.registry` looks types up here;
:mod:`.command.catalogue` refuses catalogue entries named like one of them.
"""

from __future__ import annotations

import importlib
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

from alcove.science.geometry import HeadNeckPreset
from alcove.science.oracles.base import Oracle, OracleInputError, OracleParams

OracleFactory = Callable[[OracleParams, HeadNeckPreset], Oracle]


class OracleTypeUnavailable(OracleInputError):
    """A known built-in type whose implementation cannot be imported."""


class OracleType(NamedTuple):
    params_model: type[OracleParams]
    factory: OracleFactory


@dataclass(frozen=True)
class BuiltinType:
    """Where a built-in type lives: its module, oracle class and parameter class, and what it is."""

    module: str
    oracle_class: str
    params_class: str
    description: str
    program: str | None = None  # an external program the type runs; unavailable where it is not on PATH
    package: str | None = None  # the package that installs it (named in the unavailable reason)

    def missing_program(self) -> str | None:
        """Why the type cannot run here (its program is not on PATH), or None."""
        if self.program is None or shutil.which(self.program) is not None:
            return None
        return f"the program '{self.program}' is not on PATH (install the package {self.package or self.program})"

    def load(self, name: str) -> OracleType:
        """Import the implementation; :class:`OracleTypeUnavailable` names the type and the reason."""
        try:
            module = importlib.import_module(self.module)
            oracle_cls = getattr(module, self.oracle_class)
            params_cls = getattr(module, self.params_class)
        except (ImportError, AttributeError) as exc:
            raise OracleTypeUnavailable(
                "oracle", f"type '{name}' is not available: cannot import {self.module}.{self.oracle_class} ({exc})"
            ) from None

        def factory(params: OracleParams, preset: HeadNeckPreset) -> Oracle:
            oracle: Oracle = oracle_cls(params, preset=preset)
            return oracle

        return OracleType(params_cls, factory)


#: the type of the paper's auxiliary law (the preliminary data's own law)
AUXILIARY_LAW = "aux-penalty"

BUILTIN_TYPES: dict[str, BuiltinType] = {
    "fe-headrest-2d": BuiltinType(
        "alcove.science.oracles.fe_headrest",
        "FEHeadrestOracle",
        "FEHeadrestParams",
        "Plane-strain finite-element headrest (hyperfoam cushion, rigid head, penalty contact with friction)",
    ),
    AUXILIARY_LAW: BuiltinType(
        "alcove.science.oracles.aux_penalty",
        "AuxPenaltyOracle",
        "AuxPenaltyParams",
        "The paper's auxiliary penalty model: one head point against the headrest plane (closed form)",
    ),
    "fe-headrest-3d-ccx": BuiltinType(
        "alcove.science.oracles.fe_headrest_3d",
        "CcxHeadrestOracle",
        "CcxHeadrestParams",
        "3D finite-element headrest in CalculiX (hyperfoam block, rigid ellipsoidal head, penalty contact "
        "with friction), run through the command-oracle machinery",
        program="ccx",
        package="calculix-ccx",
    ),
}
BUILTIN_TYPE_NAMES = frozenset(BUILTIN_TYPES)

__all__ = [
    "BUILTIN_TYPES",
    "BUILTIN_TYPE_NAMES",
    "BuiltinType",
    "OracleFactory",
    "OracleType",
    "OracleTypeUnavailable",
]
