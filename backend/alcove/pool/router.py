"""Routes ``/campaigns/{id}/pool-versions`` (a campaign's immutable pool versions, as tables)
and ``/preliminary-datasets`` (CSV upload of preliminary data)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, File, Form, Request, Response, UploadFile, status
from pydantic import BaseModel, ConfigDict, Field

from alcove import versioning
from alcove.api.deps import SessionDep
from alcove.api.downloads import binary, download
from alcove.api.params import IterationIndex, Limit, ObjectId, Offset
from alcove.errors import InvalidInput
from alcove.models import Campaign, TaskDefinition
from alcove.pool import repository as repo
from alcove.pool import service
from alcove.pool.schemas import PoolVersionRead
from alcove.users.access import get_for
from alcove.users.auth import CurrentUser

router = APIRouter(prefix="/campaigns", tags=["campaigns"])
uploads = APIRouter(prefix="/preliminary-datasets", tags=["datasets"])

#: Largest preliminary-data CSV accepted (the body limit for this path is larger still).
MAX_UPLOAD_BYTES = 50 * 1024 * 1024


class DatasetOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    name: str
    origin: str
    n_samples: int
    created_at: datetime


class UploadOut(BaseModel):
    datasets: list[DatasetOut]
    dataset_ids: list[int] = Field(description="pass as `preliminary.dataset_ids` of a campaign")
    n_samples: int


# ----------------------------------------------------------------------------- pool versions


@router.get(
    "/{campaign_id:integer}/pool-versions", response_model=list[PoolVersionRead], operation_id="list_pool_versions"
)
def list_pool_versions(campaign_id: ObjectId, user: CurrentUser, session: SessionDep) -> list[PoolVersionRead]:
    """Immutable pool versions (lineage: ``parent_id``; version k = k-1 + iteration k's data)."""
    get_for(session, Campaign, campaign_id, user)
    return service.campaign_versions(session, campaign_id)


@router.get(
    "/{campaign_id:integer}/pool-versions/{version:integer}/download",
    operation_id="download_pool_version",
    response_class=Response,
    responses={200: binary("application/vnd.apache.parquet", "text/csv")},
)
def download_pool_version(
    campaign_id: ObjectId,
    version: IterationIndex,
    user: CurrentUser,
    session: SessionDep,
    format: Literal["parquet", "csv"] = "parquet",
) -> Response:
    """One row per sample: dataset, origin, t, q_i, qd_i, fx..mz (Parquet or CSV)."""
    get_for(session, Campaign, campaign_id, user)
    data = service.campaign_version_table(session, campaign_id, version, format)
    media = "application/vnd.apache.parquet" if format == "parquet" else "text/csv"
    return download(data, f"campaign-{campaign_id}-pool-{version:04d}.{format}", media)


# ----------------------------------------------------------------------------- preliminary data upload

DATASET_NAME = r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$"


async def upload_name(
    request: Request,
    name: Annotated[
        str | None,
        Form(
            max_length=100,
            pattern=DATASET_NAME,
            description="stem of the datasets' names (letters, digits, _ . + -); left out: 'upload'",
        ),
    ] = None,
) -> str:
    """The upload's name. A form sends an empty field like a missing one, and FastAPI would
    quietly use the default: an empty name sent on purpose is refused instead."""
    form = await request.form()
    if "name" in form and not str(form["name"]).strip():
        raise InvalidInput.one("name", "is empty: name the data set, or leave the field out to use 'upload'")
    return name or "upload"


@uploads.post(
    "", response_model=UploadOut, status_code=status.HTTP_201_CREATED, operation_id="upload_preliminary_dataset"
)
def upload_preliminary_dataset(
    user: CurrentUser,
    session: SessionDep,
    file: Annotated[
        UploadFile, File(description="CSV with columns [simulation,] [t,] q_i, qd_i, fx, fy, fz, mx, my, mz")
    ],
    name: Annotated[str, Depends(upload_name)],
    chunks: Annotated[int, Form(ge=1, le=1000)] = 10,
    task_id: Annotated[
        int | None,
        Form(ge=1, le=2**31 - 1, description="check the values against this task's model (default: any model's range)"),
    ] = None,
) -> UploadOut:
    """Store a preliminary data set (validated: finite values within plausible ranges, joint
    angles within the task's model range when ``task_id`` is given); use the returned ids as
    a campaign's ``preliminary.dataset_ids`` (checked again against the campaign's task)."""
    from alcove.science.series import SeriesFormatError
    from alcove.science.surrogate.dataset import PoolDataError

    raw = file.file.read(MAX_UPLOAD_BYTES + 1)
    if len(raw) > MAX_UPLOAD_BYTES:
        from alcove.errors import TooLarge

        raise TooLarge(f"the file is larger than {MAX_UPLOAD_BYTES} bytes")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InvalidInput.one("file", "is not UTF-8 text") from None
    state = None
    if task_id is not None:
        task = get_for(session, TaskDefinition, task_id, user)
        state = service.state_range_of_task(versioning.latest(session, versioning.TASKS, task).spec)
    try:
        rows = service.upload_preliminary_dataset(session, user.id, text, name=name, chunks=chunks, state=state)
    except (PoolDataError, SeriesFormatError) as err:
        raise InvalidInput.one(f"file.{err.field}", err.reason) from None
    except (ValueError, IndexError) as err:
        raise InvalidInput.one("file", str(err)) from None
    session.commit()
    out = [DatasetOut.model_validate(d) for d in rows]
    return UploadOut(datasets=out, dataset_ids=[d.id for d in out], n_samples=sum(d.n_samples for d in out))


@uploads.get("", response_model=list[DatasetOut], operation_id="list_preliminary_datasets")
def list_preliminary_datasets(
    user: CurrentUser, session: SessionDep, limit: Limit = 100, offset: Offset = 0
) -> list[DatasetOut]:
    """Your uploaded data sets."""
    return [DatasetOut.model_validate(d) for d in repo.uploaded_datasets(session, user.id, limit, offset)]
