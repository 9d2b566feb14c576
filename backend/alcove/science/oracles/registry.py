"""All oracle types by name: parameter models, factories and JSON schemas for the UI.

Built-in types are imported lazily (the FE oracle pulls in scikit-fem and its own code, and
a missing module must not break the other types); command oracles come from the
administrator's catalogue (:func:`alcove.science.oracles.command.load_command_catalogue`)
and are addressed by their entry's name. The built-in table is :mod:`.builtin`.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator, Mapping
from typing import Any

from pydantic import ValidationError

from alcove.science.geometry import DEFAULT_PRESET, HeadNeckPreset
from alcove.science.oracles.base import SUMMARY_DIAGNOSTICS, Oracle, OracleInputError, OracleParams
from alcove.science.oracles.builtin import (
    BUILTIN_TYPE_NAMES,
    BUILTIN_TYPES,
    OracleFactory,
    OracleType,
    OracleTypeUnavailable,
)
from alcove.science.oracles.command import CommandOracle, CommandOracleSpec, params_model
from alcove.science.spec_checks import error_location


class _LazyOracleTypes(Mapping[str, OracleType]):
    """``ORACLE_TYPES[name] -> (params model, factory)``; imports the implementation on first use."""

    def __init__(self) -> None:
        self._loaded: dict[str, OracleType] = {}

    def __getitem__(self, name: str) -> OracleType:
        if name not in BUILTIN_TYPES:
            raise KeyError(name)
        if name not in self._loaded:
            self._loaded[name] = BUILTIN_TYPES[name].load(name)
        return self._loaded[name]

    def __iter__(self) -> Iterator[str]:
        return iter(BUILTIN_TYPES)

    def __len__(self) -> int:
        return len(BUILTIN_TYPES)


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
        raise OracleInputError(*error_location(exc.errors()[0], prefix=("params",))) from None
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
    for name, entry in BUILTIN_TYPES.items():
        try:
            ORACLE_TYPES[name]
            reason = entry.missing_program()  # on this machine; workers may differ from the API host
        except OracleTypeUnavailable as exc:
            reason = exc.reason
        available = reason is None
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
        # on this machine; workers may differ from the API host. A batch entry's program is on
        # the compute nodes: nothing to look for here.
        found = spec.launcher.is_batch or shutil.which(spec.argv[0]) is not None
        reason = None if found else f"{spec.argv[0]} is not an executable program on this machine"
        rows.append(
            {
                "name": name,
                "kind": "command",
                "description": spec.description,
                "available": found,
                "unavailable_reason": reason,
                "launcher": spec.launcher.summary() if spec.launcher.is_batch else None,
            }
        )
    return rows


def _resolve(type_name: str, catalogue: Mapping[str, CommandOracleSpec] | None) -> OracleType:
    if type_name in ORACLE_TYPES:
        return ORACLE_TYPES[type_name]
    if catalogue is not None and type_name in catalogue:
        spec = catalogue[type_name]

        def command_oracle(params: OracleParams, preset: HeadNeckPreset) -> Oracle:
            return CommandOracle(spec, params, preset=preset)

        return OracleType(params_model(spec), command_oracle)
    known = sorted(ORACLE_TYPES) + sorted(catalogue or {})
    hint = "" if catalogue else " (command oracles need the administrator's catalogue)"
    raise OracleInputError("oracle", f"unknown oracle type {type_name!r}; known: {', '.join(known)}{hint}")


__all__ = [
    "BUILTIN_TYPE_NAMES",
    "ORACLE_TYPES",
    "SUMMARY_DIAGNOSTICS",
    "OracleFactory",
    "OracleType",
    "OracleTypeUnavailable",
    "build_oracle",
    "list_oracle_types",
    "params_json_schema",
]
