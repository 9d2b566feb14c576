"""Routes ``/oracles`` (versioned oracle definitions, types and their parameter schemas,
presets, validation) and ``/admin/command-oracles`` (the administrators' catalogue)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Path, Response, status

from alcove import versioning
from alcove.api.deps import SessionDep
from alcove.api.params import Limit, ObjectId, Offset, VersionNumber
from alcove.models import OracleDefinition, User
from alcove.oracles import repository as repo
from alcove.oracles import service
from alcove.oracles.schemas import (
    CommandOracleIn,
    CommandOracleOut,
    OracleDraft,
    OracleIn,
    OracleOut,
    OraclePresetOut,
    OracleTypeOut,
    OracleUpdate,
    OracleVersionOut,
)
from alcove.users.auth import AdminUser, CurrentUser
from alcove.versioning.schemas import CheckReport, CopyPreset, FieldErrorOut

router = APIRouter(prefix="/oracles", tags=["oracles"])
admin_router = APIRouter(prefix="/admin/command-oracles", tags=["admin"])
Key = Annotated[str, Path(min_length=1, max_length=100)]


def oracle_out(
    session: SessionDep, definition: OracleDefinition, version: Any, user: User, owner_email: str | None = None
) -> OracleOut:
    return OracleOut(
        **versioning.definition_meta(session, repo.KIND, definition, version, user, owner_email),
        type=version.oracle_type,
        params=version.spec,
    )


def version_out(session: SessionDep, version: Any) -> OracleVersionOut:
    return OracleVersionOut(
        **versioning.version_meta(session, repo.KIND, version),
        type=version.oracle_type,
        params=version.spec,
    )


@router.get("", response_model=list[OracleOut], operation_id="list_oracles")
def list_oracles(
    user: CurrentUser, session: SessionDep, include_archived: bool = False, limit: Limit = 100, offset: Offset = 0
) -> list[OracleOut]:
    rows = repo.list_visible(session, user, include_archived=include_archived, limit=limit, offset=offset)
    return [oracle_out(session, d, v, user, email) for d, v, email in rows]


@router.post("", response_model=OracleOut, status_code=status.HTTP_201_CREATED, operation_id="create_oracle")
def create_oracle(body: OracleIn, user: CurrentUser, session: SessionDep) -> OracleOut:
    definition, version = service.create(
        session,
        user,
        name=body.name,
        description=body.description,
        type_name=body.type,
        params=body.params,
        note=body.note,
    )
    session.commit()
    return oracle_out(session, definition, version, user, user.email)


@router.get("/types", response_model=list[OracleTypeOut], operation_id="list_oracle_types")
def list_oracle_types(user: CurrentUser, session: SessionDep) -> list[OracleTypeOut]:
    """Built-in types and the catalogue's command oracles, each with its parameters' JSON Schema."""
    return [OracleTypeOut(**t) for t in service.types(session)]


@router.get("/types/{type_name}/schema", response_model=dict[str, Any], operation_id="get_oracle_params_schema")
def get_oracle_params_schema(type_name: Key, user: CurrentUser, session: SessionDep) -> dict[str, Any]:
    return service.params_schema(session, type_name)


@router.get("/presets", response_model=list[OraclePresetOut], operation_id="list_oracle_presets")
def list_oracle_presets(user: CurrentUser) -> list[OraclePresetOut]:
    return [OraclePresetOut(**p) for p in service.presets()]


@router.post(
    "/presets/{key}/copy",
    response_model=OracleOut,
    status_code=status.HTTP_201_CREATED,
    operation_id="copy_oracle_preset",
)
def copy_oracle_preset(key: Key, user: CurrentUser, session: SessionDep, body: CopyPreset | None = None) -> OracleOut:
    definition, version = service.copy_preset(session, user, key, body.name if body else None)
    session.commit()
    return oracle_out(session, definition, version, user, user.email)


@router.post("/check", response_model=CheckReport, operation_id="check_oracle")
def check_oracle(body: OracleDraft, user: CurrentUser, session: SessionDep) -> CheckReport:
    """Check a type and its parameters without saving (paths like ``params.friction``)."""
    normalized, errors = service.check(session, body.type, body.params)
    return CheckReport(
        valid=normalized is not None, errors=[FieldErrorOut.of(e) for e in errors], normalized=normalized
    )


@router.get("/{oracle_id:integer}", response_model=OracleOut, operation_id="get_oracle")
def get_oracle(oracle_id: ObjectId, user: CurrentUser, session: SessionDep) -> OracleOut:
    definition = repo.get_oracle(session, oracle_id, user)
    return oracle_out(session, definition, repo.latest_version(session, definition), user)


@router.put("/{oracle_id:integer}", response_model=OracleOut, operation_id="update_oracle")
def update_oracle(oracle_id: ObjectId, body: OracleUpdate, user: CurrentUser, session: SessionDep) -> OracleOut:
    """Rename or edit; a changed type/params creates a new version once a campaign uses the latest one."""
    definition, version = service.update(
        session,
        user,
        oracle_id,
        name=body.name,
        description=body.description,
        type_name=body.type,
        params=body.params,
        note=body.note,
    )
    session.commit()
    return oracle_out(session, definition, version, user)


@router.delete("/{oracle_id:integer}", status_code=status.HTTP_204_NO_CONTENT, operation_id="delete_oracle")
def delete_oracle(oracle_id: ObjectId, user: CurrentUser, session: SessionDep) -> Response:
    service.delete(session, user, oracle_id)
    session.commit()
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get("/{oracle_id:integer}/versions", response_model=list[OracleVersionOut], operation_id="list_oracle_versions")
def list_oracle_versions(oracle_id: ObjectId, user: CurrentUser, session: SessionDep) -> list[OracleVersionOut]:
    definition = repo.get_oracle(session, oracle_id, user)
    return [version_out(session, v) for v in repo.versions(session, definition)]


@router.get(
    "/{oracle_id:integer}/versions/{version:integer}",
    response_model=OracleVersionOut,
    operation_id="get_oracle_version",
)
def get_oracle_version(
    oracle_id: ObjectId, version: VersionNumber, user: CurrentUser, session: SessionDep
) -> OracleVersionOut:
    definition = repo.get_oracle(session, oracle_id, user)
    return version_out(session, repo.get_version(session, definition, version))


# ----------------------------------------------------------------------------- admin catalogue


@admin_router.get("", response_model=list[CommandOracleOut], operation_id="list_command_oracles")
def list_command_oracles(admin: AdminUser, session: SessionDep) -> list[CommandOracleOut]:
    """Entries managed through the API (the settings' YAML catalogue is listed in ``/oracles/types``)."""
    return [CommandOracleOut.model_validate(r) for r in service.list_commands(session)]


@admin_router.post(
    "", response_model=CommandOracleOut, status_code=status.HTTP_201_CREATED, operation_id="create_command_oracle"
)
def create_command_oracle(body: CommandOracleIn, admin: AdminUser, session: SessionDep) -> CommandOracleOut:
    row = service.create_command(session, admin, body)
    session.commit()
    return CommandOracleOut.model_validate(row)


@admin_router.get("/{entry_id:integer}", response_model=CommandOracleOut, operation_id="get_command_oracle")
def get_command_oracle(entry_id: ObjectId, admin: AdminUser, session: SessionDep) -> CommandOracleOut:
    return CommandOracleOut.model_validate(service.get_command(session, entry_id))


@admin_router.put("/{entry_id:integer}", response_model=CommandOracleOut, operation_id="update_command_oracle")
def update_command_oracle(
    entry_id: ObjectId, body: CommandOracleIn, admin: AdminUser, session: SessionDep
) -> CommandOracleOut:
    row = service.update_command(session, entry_id, body)
    session.commit()
    return CommandOracleOut.model_validate(row)


@admin_router.delete(
    "/{entry_id:integer}", status_code=status.HTTP_204_NO_CONTENT, operation_id="delete_command_oracle"
)
def delete_command_oracle(entry_id: ObjectId, admin: AdminUser, session: SessionDep) -> Response:
    """Remove an entry; oracles referring to it stop validating (disable it to keep them listed)."""
    service.delete_command(session, entry_id)
    session.commit()
    return Response(status_code=status.HTTP_204_NO_CONTENT)
