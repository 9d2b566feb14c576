"""Oracle definitions: type + parameters validated by the oracle registry (no oracle code
runs in the API), versioned CRUD, presets, and the command catalogue (the settings' YAML
file plus the entries administrators manage through the API)."""

from __future__ import annotations

import logging
from collections.abc import Mapping
from typing import Any

from pydantic import ValidationError
from sqlalchemy.orm import Session

from alcove import versioning
from alcove.errors import Conflict, FieldError, InvalidInput, NotFound, field_errors_from_pydantic
from alcove.models import CommandOracle, OracleDefinition, User
from alcove.oracles import repository as repo
from alcove.oracles.schemas import CommandOracleIn
from alcove.science.oracles.base import OracleInputError, OracleParams
from alcove.science.oracles.registry import BUILTIN_TYPE_NAMES, ORACLE_TYPES, list_oracle_types
from alcove.settings import get_settings

log = logging.getLogger(__name__)

KIND = repo.KIND

#: Presets: one per built-in type, with the type's default parameters.
PRESETS: dict[str, dict[str, str]] = {
    "aux-penalty": {
        "name": "aux-penalty",
        "type": "aux-penalty",
        "description": "The paper's auxiliary penalty model (closed form, fast): the default parameters of the paper.",
    },
    "fe-headrest-2d": {
        "name": "fe-headrest-2d",
        "type": "fe-headrest-2d",
        "description": (
            "Plane-strain FE headrest (hyperfoam cushion, penalty contact with friction), default parameters."
        ),
    },
    "fe-headrest-3d-ccx": {
        "name": "fe-headrest-3d-ccx",
        "type": "fe-headrest-3d-ccx",
        "description": (
            "3D FE headrest in CalculiX (hyperfoam block, rigid ellipsoidal head, penalty contact with friction), "
            "default parameters; needs ccx on the oracle workers."
        ),
    },
}


# ----------------------------------------------------------------------------- catalogue


def _spec_from_row(row: CommandOracle) -> Any:
    from alcove.science.oracles.command import CommandOracleSpec

    return CommandOracleSpec(
        name=row.name,
        description=row.description,
        argv=list(row.argv),
        env=dict(row.env or {}),
        timeout_s=row.timeout_s,
        workdir_root=row.working_dir,
        launcher=row.launcher or {},
    )


def builtin_launchers() -> dict[str, Any]:
    """Where built-in types that run a program (fe-headrest-3d-ccx) run: the catalogue file's
    ``launchers`` section (type name -> ``LauncherSpec``); none: on the oracle worker."""
    path = get_settings().command_oracles_file
    if path is None:
        return {}
    from alcove.science.oracles.command import CatalogueError
    from alcove.science.oracles.command.catalogue import load_builtin_launchers

    try:
        return load_builtin_launchers(path)
    except CatalogueError as err:
        log.error("command catalogue %s is invalid: %s", path, err)
        return {}


def file_catalogue() -> dict[str, Any]:
    path = get_settings().command_oracles_file
    if path is None:
        return {}
    from alcove.science.oracles.command import CatalogueError, load_command_catalogue

    try:
        return load_command_catalogue(path)
    except CatalogueError as err:
        log.error("command catalogue %s is invalid: %s", path, err)
        return {}


def command_catalogue(session: Session) -> dict[str, Any]:
    """Every command oracle users may pick: the settings' YAML catalogue plus the enabled
    entries administrators added through the API (name -> ``CommandOracleSpec``). The
    campaign engine should resolve command oracles through this function."""
    catalogue = file_catalogue()
    for row in repo.commands(session, enabled_only=True):
        catalogue.setdefault(row.name, _spec_from_row(row))
    return catalogue


def check_command_entry(body: CommandOracleIn) -> None:
    from alcove.science.oracles.command import CommandOracleSpec

    if body.name in BUILTIN_TYPE_NAMES:
        raise InvalidInput.one("name", f"is a built-in oracle type ({', '.join(sorted(BUILTIN_TYPE_NAMES))})")
    if body.name in file_catalogue():
        raise Conflict(f"{body.name!r} is defined in the server's catalogue file")
    try:
        CommandOracleSpec(
            name=body.name,
            description=body.description,
            argv=body.argv,
            env=body.env,
            timeout_s=body.timeout_s,
            workdir_root=body.working_dir,
            launcher=body.launcher or {},
        )
    except ValidationError as err:
        raise InvalidInput(field_errors_from_pydantic(err)) from None


def create_command(session: Session, admin: User, body: CommandOracleIn) -> CommandOracle:
    check_command_entry(body)
    if repo.command_exists(session, body.name):
        raise Conflict(f"name: a command oracle named {body.name!r} exists")
    return repo.add_command(session, CommandOracle(**_row_values(body), created_by_id=admin.id))


def _row_values(body: CommandOracleIn) -> dict[str, Any]:
    """The entry's columns; a launcher is stored with the values set (NULL: on the oracle worker)."""
    values = body.model_dump(mode="json", exclude={"launcher"})
    launcher = body.launcher
    values["launcher"] = (
        launcher.model_dump(mode="json", exclude_defaults=True) if launcher and launcher.is_batch else None
    )
    return values


def list_commands(session: Session) -> list[CommandOracle]:
    return repo.commands(session)


def get_command(session: Session, entry_id: int) -> CommandOracle:
    row = repo.get_command(session, entry_id)
    if row is None:
        raise NotFound("command oracle", entry_id)
    return row


def update_command(session: Session, entry_id: int, body: CommandOracleIn) -> CommandOracle:
    row = get_command(session, entry_id)
    if body.name != row.name:
        raise InvalidInput.one("name", "cannot be changed (oracles refer to the entry by name); create a new entry")
    check_command_entry(body)
    for key, value in _row_values(body).items():
        setattr(row, key, value)
    session.flush()
    return row


def delete_command(session: Session, entry_id: int) -> None:
    repo.delete_command(session, get_command(session, entry_id))


# ----------------------------------------------------------------------------- types and params


def _params_model(type_name: str, catalogue: Mapping[str, Any]) -> type[OracleParams]:
    if type_name in ORACLE_TYPES:
        return ORACLE_TYPES[type_name].params_model
    if type_name in catalogue:
        from alcove.science.oracles.command import params_model

        return params_model(catalogue[type_name])
    known = sorted(ORACLE_TYPES) + sorted(catalogue)
    raise InvalidInput.one("type", f"unknown oracle type {type_name!r}; known: {', '.join(known)}")


def check(session: Session, type_name: str, params: Any) -> tuple[dict[str, Any] | None, list[FieldError]]:
    """Validate type + params; returns (normalized params, []) or (None, field errors)."""
    try:
        model = _params_model(type_name, command_catalogue(session))
    except InvalidInput as err:
        return None, err.errors
    except OracleInputError as err:  # a built-in type whose implementation cannot be imported here
        return None, [FieldError(("type",), err.reason)]
    if not isinstance(params, Mapping):
        return None, [FieldError(("params",), "must be a JSON object")]
    try:
        return model.model_validate(dict(params)).model_dump(mode="json"), []
    except ValidationError as err:
        return None, field_errors_from_pydantic(err, base=("params",))


def require_valid(session: Session, type_name: str, params: Any) -> dict[str, Any]:
    normalized, errors = check(session, type_name, params)
    if normalized is None:
        raise InvalidInput(errors)
    return normalized


def types(session: Session) -> list[dict[str, Any]]:
    catalogue = command_catalogue(session)
    launchers = builtin_launchers()
    out = []
    for row in list_oracle_types(catalogue):
        launcher = launchers.get(row["name"])
        if launcher is not None and launcher.is_batch:  # its program is on the compute nodes, not here
            row = {**row, "available": True, "unavailable_reason": None, "launcher": launcher.summary()}
        try:
            schema = _params_model(row["name"], catalogue).model_json_schema()
        except (InvalidInput, OracleInputError):
            schema = {}
        out.append({**row, "params_schema": schema})
    return out


def params_schema(session: Session, type_name: str) -> dict[str, Any]:
    try:
        return _params_model(type_name, command_catalogue(session)).model_json_schema()
    except InvalidInput:
        raise NotFound("oracle type", type_name) from None


def presets() -> list[dict[str, Any]]:
    out = []
    for key, p in PRESETS.items():
        try:
            params = ORACLE_TYPES[p["type"]].params_model().model_dump(mode="json")
        except OracleInputError:
            continue
        out.append({"key": key, **p, "params": params})
    return out


# ----------------------------------------------------------------------------- definitions


def create(
    session: Session,
    owner: User,
    *,
    name: str,
    description: str,
    type_name: str,
    params: Any,
    note: str = "",
    preset_key: str | None = None,
) -> tuple[OracleDefinition, Any]:
    normalized = require_valid(session, type_name, params)
    return versioning.create(
        session,
        KIND,
        owner,
        name=name,
        description=description,
        spec=normalized,
        preset_key=preset_key,
        note=note,
        oracle_type=type_name,
    )


def update(
    session: Session,
    user: User,
    oracle_id: int,
    *,
    name: str | None,
    description: str | None,
    type_name: str | None,
    params: Any,
    note: str,
) -> tuple[OracleDefinition, Any]:
    definition = repo.get_oracle(session, oracle_id, user, need="edit")
    current = repo.latest_version(session, definition)
    spec = None
    extra: dict[str, Any] = {}
    if type_name is not None or params is not None:
        new_type = type_name or current.oracle_type
        new_params = params if params is not None else (current.spec if new_type == current.oracle_type else {})
        spec = require_valid(session, new_type, new_params)
        extra["oracle_type"] = new_type
    version, _ = versioning.update(
        session, KIND, definition, user, name=name, description=description, spec=spec, note=note, **extra
    )
    return definition, version


def delete(session: Session, user: User, oracle_id: int) -> None:
    """Delete ``user``'s oracle definition; one a campaign used is archived instead. Never commits."""
    versioning.delete(session, KIND, repo.get_oracle(session, oracle_id, user, need="owner"))


def copy_preset(session: Session, owner: User, key: str, name: str | None) -> tuple[OracleDefinition, Any]:
    preset = next((p for p in presets() if p["key"] == key), None)
    if preset is None:
        raise NotFound("oracle preset", key)
    return create(
        session,
        owner,
        name=name or preset["name"],
        description=preset["description"],
        type_name=preset["type"],
        params=preset["params"],
        preset_key=key,
        note=f"copied from preset {key}",
    )
