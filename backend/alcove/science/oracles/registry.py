"""All oracle types by name: parameter models, factories and JSON schemas for the UI.

Built-in types are imported lazily (the FE oracle pulls in scikit-fem and its own code, and
a missing module must not break the other types); command oracles come from the
administrator's catalogue (:func:`alcove.science.oracles.command.load_command_catalogue`)
and are addressed by their entry's name.
"""

from __future__ import annotations

import importlib
import shutil
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

from pydantic import ValidationError

from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset
from alcove.science.oracles.base import Oracle, OracleInputError, OracleParams

if TYPE_CHECKING:
    from alcove.science.oracles.command import CommandOracleSpec

OracleFactory = Callable[[OracleParams, HeadNeckPreset], Oracle]

#: Diagnostics every oracle reports (None where it has no such thing), shown by ``alcove
#: oracle run --json`` and the UI: deepest penetration [m], energy dissipated by the contact
#: [J], total Newton iterations.
SUMMARY_DIAGNOSTICS = ("max_penetration_m", "dissipated_energy_j", "newton_iterations")


class OracleTypeUnavailable(OracleInputError):
    """A known built-in type whose implementation cannot be imported."""


class OracleType(NamedTuple):
    params_model: type[OracleParams]
    factory: OracleFactory


@dataclass(frozen=True)
class _BuiltinType:
    module: str
    oracle_class: str
    params_class: str
    description: str

    def load(self, name: str) -> OracleType:
        try:
            module = importlib.import_module(self.module)
            oracle_cls = getattr(module, self.oracle_class)
            params_cls = getattr(module, self.params_class)
        except (ImportError, AttributeError) as exc:
            raise OracleTypeUnavailable(
                "oracle", f"type '{name}' is not available: cannot import {self.module}.{self.oracle_class} ({exc})"
            ) from None
        return OracleType(params_cls, lambda params, preset: oracle_cls(params, preset=preset))


_BUILTIN: dict[str, _BuiltinType] = {
    "fe-headrest-2d": _BuiltinType(
        "alcove.science.oracles.fe_headrest",
        "FEHeadrestOracle",
        "FEHeadrestParams",
        "Plane-strain finite-element headrest (hyperfoam cushion, rigid head, penalty contact with friction)",
    ),
    "aux-penalty": _BuiltinType(
        "alcove.science.oracles.aux_penalty",
        "AuxPenaltyOracle",
        "AuxPenaltyParams",
        "The paper's auxiliary penalty model: one head point against the headrest plane (closed form)",
    ),
}
BUILTIN_TYPE_NAMES = frozenset(_BUILTIN)


class _LazyOracleTypes(Mapping[str, OracleType]):
    """``ORACLE_TYPES[name] -> (params model, factory)``; imports the implementation on first use."""

    def __init__(self) -> None:
        self._loaded: dict[str, OracleType] = {}

    def __getitem__(self, name: str) -> OracleType:
        if name not in _BUILTIN:
            raise KeyError(name)
        if name not in self._loaded:
            self._loaded[name] = _BUILTIN[name].load(name)
        return self._loaded[name]

    def __iter__(self) -> Iterator[str]:
        return iter(_BUILTIN)

    def __len__(self) -> int:
        return len(_BUILTIN)


ORACLE_TYPES: Mapping[str, OracleType] = _LazyOracleTypes()


def build_oracle(
    type_name: str,
    params: Mapping[str, Any] | None = None,
    preset: HeadNeckPreset = DEFAULT_PRESET,
    catalogue: Mapping[str, CommandOracleSpec] | None = None,
) -> Oracle:
    """An oracle of a built-in type or a catalogue entry, with validated parameters.

    Raises :class:`OracleInputError` naming the field (``oracle`` for an unknown type,
    ``params.<name>`` for a bad parameter).
    """
    model, make = _resolve(type_name, catalogue)
    if params is not None and not isinstance(params, Mapping):
        raise OracleInputError("params", f"must be a JSON object, got {type(params).__name__}")
    try:
        validated = model.model_validate(dict(params or {}))
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(p) for p in err["loc"])
        raise OracleInputError(f"params.{loc}" if loc else "params", err["msg"]) from None
    return make(validated, preset)


def params_json_schema(type_name: str, catalogue: Mapping[str, CommandOracleSpec] | None = None) -> dict[str, Any]:
    """JSON schema of the parameters of a type (for the UI's forms)."""
    model, _ = _resolve(type_name, catalogue)
    return model.model_json_schema()


def list_oracle_types(catalogue: Mapping[str, CommandOracleSpec] | None = None) -> list[dict[str, Any]]:
    """Every type users can choose: name, kind (``builtin``/``command``), description, availability.

    A command entry is available when its program is found here (``shutil.which``): on the API
    host this says little if the solver is installed on the workers only.
    """
    rows: list[dict[str, Any]] = []
    for name, entry in _BUILTIN.items():
        try:
            ORACLE_TYPES[name]
            available, reason = True, None
        except OracleTypeUnavailable as exc:
            available, reason = False, exc.reason
        rows.append(
            {
                "name": name,
                "kind": "builtin",
                "description": entry.description,
                "available": available,
                "unavailable_reason": reason,
            }
        )
    for name, spec in (catalogue or {}).items():
        found = shutil.which(spec.argv[0]) is not None  # on this machine; workers may differ from the API host
        reason = None if found else f"{spec.argv[0]} is not an executable program on this machine"
        rows.append(
            {
                "name": name,
                "kind": "command",
                "description": spec.description,
                "available": found,
                "unavailable_reason": reason,
            }
        )
    return rows


def _resolve(
    type_name: str, catalogue: Mapping[str, CommandOracleSpec] | None
) -> tuple[type[OracleParams], OracleFactory]:
    if type_name in ORACLE_TYPES:
        return ORACLE_TYPES[type_name]
    if catalogue is not None and type_name in catalogue:
        from alcove.science.oracles.command import CommandOracle, params_model  # the command module imports this one

        spec = catalogue[type_name]
        return params_model(spec), lambda params, preset: CommandOracle(spec, params, preset=preset)
    known = sorted(ORACLE_TYPES) + sorted(catalogue or {})
    hint = "" if catalogue else " (command oracles need the administrator's catalogue)"
    raise OracleInputError("oracle", f"unknown oracle type {type_name!r}; known: {', '.join(known)}{hint}")
