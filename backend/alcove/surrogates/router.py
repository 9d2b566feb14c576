"""Routes ``/surrogate-configs`` (versioned surrogate settings: architectures, training
protocol, validated by :class:`alcove.science.surrogate.config.SurrogateConfig`) and
``/campaigns/{id}/model-versions`` (a campaign's trained models and their artifacts)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Response, status
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from sqlalchemy.orm import Session

from alcove import versioning
from alcove.api.deps import SessionDep
from alcove.api.downloads import binary, download
from alcove.api.errors import ErrorOut
from alcove.api.params import Limit, ObjectId, Offset, VersionNumber
from alcove.errors import field_errors_from_pydantic
from alcove.models import ArtifactBuild, Campaign, SurrogateConfigDefinition, User
from alcove.names import Name
from alcove.science.surrogate.config import SurrogateConfig
from alcove.surrogates import artifact_builds, service
from alcove.surrogates.schemas import ArtifactBuildRead, ModelVersionRead
from alcove.surrogates.service import artifact_document
from alcove.users.access import get_for
from alcove.users.auth import CurrentUser
from alcove.users.limits import check_sizes, surrogate_sizes
from alcove.versioning.schemas import CheckReport, DefinitionMeta, FieldErrorOut, VersionMeta

router = APIRouter(prefix="/surrogate-configs", tags=["surrogate-configs"])
model_versions = APIRouter(prefix="/campaigns", tags=["campaigns"])
KIND = versioning.SURROGATE_CONFIGS


class _In(BaseModel):
    # strict: "1" is not a number and 1 or "true" not a boolean, as the schema says (JSON numbers still fill floats)
    model_config = ConfigDict(extra="forbid", strict=True)


class SurrogateConfigIn(_In):
    name: Name
    description: str = Field("", max_length=20_000)
    spec: SurrogateConfig = Field(
        default_factory=SurrogateConfig, description="defaults: the paper's networks and training protocol"
    )
    note: str = Field("", max_length=2000)


class SurrogateConfigUpdate(_In):
    name: Name | None = None
    description: str | None = Field(None, max_length=20_000)
    spec: SurrogateConfig | None = None
    note: str = Field("", max_length=2000)


class SurrogateConfigDraft(_In):
    spec: dict[str, Any]


class SurrogateConfigOut(DefinitionMeta):
    spec: dict[str, Any]


class SurrogateConfigVersionOut(VersionMeta):
    spec: dict[str, Any]


def config_out(
    session: SessionDep, definition: SurrogateConfigDefinition, version: Any, user: User, owner_email: str | None = None
) -> SurrogateConfigOut:
    return SurrogateConfigOut(
        **versioning.definition_meta(session, KIND, definition, version, user, owner_email),
        spec=version.spec,
    )


def version_out(session: SessionDep, version: Any) -> SurrogateConfigVersionOut:
    return SurrogateConfigVersionOut(
        **versioning.version_meta(session, KIND, version),
        spec=version.spec,
    )


@router.get("", response_model=list[SurrogateConfigOut], operation_id="list_surrogate_configs")
def list_surrogate_configs(
    user: CurrentUser, session: SessionDep, include_archived: bool = False, limit: Limit = 100, offset: Offset = 0
) -> list[SurrogateConfigOut]:
    rows = versioning.list_visible(session, KIND, user, include_archived=include_archived, limit=limit, offset=offset)
    return [config_out(session, d, v, user, email) for d, v, email in rows]


@router.post(
    "", response_model=SurrogateConfigOut, status_code=status.HTTP_201_CREATED, operation_id="create_surrogate_config"
)
def create_surrogate_config(body: SurrogateConfigIn, user: CurrentUser, session: SessionDep) -> SurrogateConfigOut:
    """Create a surrogate config; one above your job limits (ensemble size, layers, widths, epochs) is refused."""
    check_sizes(session, user.id, surrogate_sizes(body.spec.model_dump(mode="json")))
    definition, version = service.create_config(
        session, user, name=body.name, description=body.description, spec=body.spec, note=body.note
    )
    session.commit()
    return config_out(session, definition, version, user, user.email)


@router.get("/schema", response_model=dict[str, Any], operation_id="get_surrogate_config_schema")
def get_surrogate_config_schema(user: CurrentUser) -> dict[str, Any]:
    return SurrogateConfig.model_json_schema()


@router.post("/check", response_model=CheckReport, operation_id="check_surrogate_config")
def check_surrogate_config(body: SurrogateConfigDraft, user: CurrentUser) -> CheckReport:
    try:
        spec = SurrogateConfig.model_validate(body.spec)
    except ValidationError as err:
        errors = field_errors_from_pydantic(err, base=("spec",))
        return CheckReport(valid=False, errors=[FieldErrorOut.of(e) for e in errors])
    return CheckReport(valid=True, errors=[], normalized=spec.model_dump(mode="json"))


@router.get("/{config_id:integer}", response_model=SurrogateConfigOut, operation_id="get_surrogate_config")
def get_surrogate_config(config_id: ObjectId, user: CurrentUser, session: SessionDep) -> SurrogateConfigOut:
    definition = get_for(session, SurrogateConfigDefinition, config_id, user)
    return config_out(session, definition, versioning.latest(session, KIND, definition), user)


@router.put("/{config_id:integer}", response_model=SurrogateConfigOut, operation_id="update_surrogate_config")
def update_surrogate_config(
    config_id: ObjectId, body: SurrogateConfigUpdate, user: CurrentUser, session: SessionDep
) -> SurrogateConfigOut:
    definition, version = service.update_config(
        session, user, config_id, name=body.name, description=body.description, spec=body.spec, note=body.note
    )
    session.commit()
    return config_out(session, definition, version, user)


@router.delete("/{config_id:integer}", status_code=status.HTTP_204_NO_CONTENT, operation_id="delete_surrogate_config")
def delete_surrogate_config(config_id: ObjectId, user: CurrentUser, session: SessionDep) -> Response:
    service.delete_config(session, user, config_id)
    session.commit()
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get(
    "/{config_id:integer}/versions",
    response_model=list[SurrogateConfigVersionOut],
    operation_id="list_surrogate_config_versions",
)
def list_surrogate_config_versions(
    config_id: ObjectId, user: CurrentUser, session: SessionDep
) -> list[SurrogateConfigVersionOut]:
    definition = get_for(session, SurrogateConfigDefinition, config_id, user)
    return [version_out(session, v) for v in versioning.versions(session, KIND, definition)]


@router.get(
    "/{config_id:integer}/versions/{version:integer}",
    response_model=SurrogateConfigVersionOut,
    operation_id="get_surrogate_config_version",
)
def get_surrogate_config_version(
    config_id: ObjectId, version: VersionNumber, user: CurrentUser, session: SessionDep
) -> SurrogateConfigVersionOut:
    definition = get_for(session, SurrogateConfigDefinition, config_id, user)
    return version_out(session, versioning.get_version(session, KIND, definition, version))


# ----------------------------------------------------------------------------- model versions


@model_versions.get(
    "/{campaign_id:integer}/model-versions", response_model=list[ModelVersionRead], operation_id="list_model_versions"
)
def list_model_versions(campaign_id: ObjectId, user: CurrentUser, session: SessionDep) -> list[ModelVersionRead]:
    """Trained models with lineage (pool version, parent model, seed, code and library versions)."""
    get_for(session, Campaign, campaign_id, user)
    return service.campaign_versions(session, campaign_id)


@model_versions.get(
    "/{campaign_id:integer}/model-versions/{version:integer}/artifact",
    response_model=dict[str, Any],
    operation_id="get_model_artifact",
)
def get_model_artifact(
    campaign_id: ObjectId, version: VersionNumber, user: CurrentUser, session: SessionDep
) -> dict[str, Any]:
    """The self-contained artifact document (architecture, weights, normalisation, lineage) as JSON."""
    get_for(session, Campaign, campaign_id, user)
    return artifact_document(session, service.campaign_version(session, campaign_id, version))


#: The answers of a download that may need an artifact build.
BUILD_RESPONSES: dict[int | str, dict[str, Any]] = {
    202: {
        "model": ArtifactBuildRead,
        "description": "the model zips are being built: poll the build (the Location header) until it is ready, "
        "then repeat this download",
    },
    503: {
        "model": ErrorOut,
        "description": "the artifacts folder is read-only or not writable (named), or the database is busy",
    },
    507: {"model": ErrorOut, "description": "the artifacts folder is full (named)"},
}


def build_accepted(session: Session, row: ArtifactBuild) -> JSONResponse:
    """202 with the build (committed: its job is sent now, or by the outbox relay)."""
    artifact_builds.send(row.id)
    return JSONResponse(
        artifact_builds.read(session, row).model_dump(mode="json"),
        status_code=status.HTTP_202_ACCEPTED,
        headers={"Location": f"/api/v1/campaigns/{row.campaign_id}/artifact-builds/{row.id}", "Retry-After": "1"},
    )


@model_versions.get(
    "/{campaign_id:integer}/model-versions/{version:integer}/artifact.zip",
    operation_id="download_model_artifact",
    response_class=Response,
    responses={200: binary("application/zip"), **BUILD_RESPONSES},
)
def download_model_artifact(
    campaign_id: ObjectId, version: VersionNumber, user: CurrentUser, session: SessionDep
) -> Response:
    """The artifact as a zip: ``surrogate.json`` + TorchScript ``force.pt`` / ``moment.pt`` + the
    CasADi and ONNX exports. Built once by a worker (queue ``artifacts``), then stored: until it
    is, the answer is 202 with the build to poll."""
    get_for(session, Campaign, campaign_id, user)
    mv = service.campaign_version(session, campaign_id, version)
    path = f"/api/v1/campaigns/{campaign_id}/model-versions/{version}/artifact.zip"
    got = artifact_builds.stored_or_build(session, user, campaign_id, [mv], path)
    if isinstance(got, ArtifactBuild):
        return build_accepted(session, got)
    return download(got[mv.id].read_bytes(), f"campaign-{campaign_id}-model-{version:04d}.zip", "application/zip")


@model_versions.get(
    "/{campaign_id:integer}/artifact-builds/{build_id:integer}",
    response_model=ArtifactBuildRead,
    operation_id="get_artifact_build",
)
def get_artifact_build(
    campaign_id: ObjectId, build_id: ObjectId, user: CurrentUser, session: SessionDep
) -> ArtifactBuildRead:
    """A build of model artifact zips a download waits for: its status and progress."""
    return artifact_builds.read(session, artifact_builds.get(session, user, campaign_id, build_id))
