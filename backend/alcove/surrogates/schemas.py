"""Pydantic schemas of model versions."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, computed_field

from alcove.science.surrogate.metrics import DESCRIPTIONS


class _Read(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class ModelVersionRead(_Read):
    id: int
    campaign_id: int | None
    version: int
    pool_version_id: int
    parent_model_id: int | None
    surrogate_config_version_id: int | None
    seed: int
    test_force_rmse: float | None = Field(
        description="the members' mean, on each member's own test simulations, of the " + DESCRIPTIONS["force_rmse"]
    )
    test_moment_rmse: float | None = Field(
        description="the members' mean, on each member's own test simulations, of the " + DESCRIPTIONS["moment_rmse"]
    )
    epochs: int | None
    train_wall_time_s: float | None
    code_version: str
    library_versions: dict[str, Any]
    architecture: dict[str, Any]
    training_metrics: dict[str, Any]
    created_at: datetime

    @computed_field(  # type: ignore[prop-decorator]
        description="nets, over the members, that stopped at max_epochs while their validation loss was still "
        "improving (more epochs would likely have lowered the error); 0 for models trained before this was recorded"
    )
    @property
    def stopped_improving(self) -> int:
        value = self.training_metrics.get("stopped_improving", 0)
        return value if isinstance(value, int) else 0


__all__ = ["ModelVersionRead"]


class ArtifactBuildRead(_Read):
    """A build of the model artifact zips a download needs. Poll it (``GET
    /artifact-builds/{id}``) until ``status`` is ``ready``, then repeat the download
    (``download_url``); ``failed`` says why in ``error``."""

    id: int
    campaign_id: int
    status: str = Field(description="queued, running, ready or failed")
    models_total: int = Field(description="model zips this build makes")
    models_done: int = Field(description="of which stored so far")
    detail: str = Field(description="what it is doing or waiting for, in words")
    error: str | None
    download_url: str = Field(description="the download to repeat once the build is ready")
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
