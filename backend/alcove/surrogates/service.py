"""Surrogate configurations and trained surrogates: create a configuration; store and load
trained surrogates.

A model version keeps two blobs: ``weights_sha256`` (``.npz`` of every parameter, for
diffing and numerical use) and ``artifact_sha256`` (the artifact JSON of
:mod:`alcove.science.surrogate.artifact`, from which the model is rebuilt exactly; JSON
floats round-trip). ``artifact_zip`` adds the TorchScript files for use outside alcove.
Torch is imported only inside the functions that need it.
"""

from __future__ import annotations

import io
import json
import platform
import tempfile
import threading
import zipfile
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from cachetools import LRUCache
from sqlalchemy.orm import Session

import alcove
from alcove import versioning
from alcove.db.arrays import get_bytes, put_arrays, put_bytes
from alcove.errors import NotFound
from alcove.models import ModelVersion, SurrogateConfigDefinition, SurrogateConfigVersion, User
from alcove.surrogates import repository as repo
from alcove.surrogates.schemas import ModelVersionRead
from alcove.users.access import get_for
from alcove.users.limits import check_sizes, surrogate_sizes

if TYPE_CHECKING:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.mlp import SurrogateModel
    from alcove.science.surrogate.training import TrainingResult

ARTIFACT_MEDIA_TYPE = "application/vnd.alcove.surrogate+json"

_lock = threading.Lock()
#: Trained models by artifact hash (artifacts are immutable).
_models: LRUCache[str, SurrogateModel] = LRUCache(maxsize=16)


def create_config(
    session: Session,
    owner: User,
    *,
    name: str,
    description: str,
    spec: SurrogateConfig,
    note: str = "",
    preset_key: str | None = None,
) -> tuple[SurrogateConfigDefinition, SurrogateConfigVersion]:
    """A surrogate configuration of ``owner`` with its version 1 (the validated ``spec``, stored
    normalised). Never commits."""
    return versioning.create(
        session,
        versioning.SURROGATE_CONFIGS,
        owner,
        name=name,
        description=description,
        spec=spec.model_dump(mode="json"),
        preset_key=preset_key,
        note=note,
    )


def update_config(
    session: Session,
    user: User,
    config_id: int,
    *,
    name: str | None,
    description: str | None,
    spec: SurrogateConfig | None,
    note: str,
) -> tuple[SurrogateConfigDefinition, SurrogateConfigVersion]:
    """Rename or edit a configuration ``user`` may edit: a changed ``spec`` (within the owner's
    job limits) edits the latest version while no campaign uses it, and otherwise makes a new
    version. Never commits."""
    definition = get_for(session, SurrogateConfigDefinition, config_id, user, need="edit")
    raw = None if spec is None else spec.model_dump(mode="json")
    if raw is not None:
        check_sizes(session, user.id, surrogate_sizes(raw))
    version, _ = versioning.update(
        session,
        versioning.SURROGATE_CONFIGS,
        definition,
        user,
        name=name,
        description=description,
        spec=raw,
        note=note,
    )
    return definition, version


def delete_config(session: Session, user: User, config_id: int) -> None:
    """Delete ``user``'s configuration; one a campaign used is archived instead. Never commits."""
    definition = get_for(session, SurrogateConfigDefinition, config_id, user, need="owner")
    versioning.delete(session, versioning.SURROGATE_CONFIGS, definition)


@lru_cache
def code_version() -> str:
    """alcove's version plus the git commit when running from a checkout."""
    import subprocess

    root = Path(alcove.__file__).resolve().parents[2]
    try:
        commit = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=5
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    return f"{alcove.__version__}+{commit}" if commit else alcove.__version__


@lru_cache
def library_versions() -> dict[str, str]:
    import casadi
    import scipy
    import torch

    return {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "torch": torch.__version__,
        "casadi": casadi.__version__,  # type: ignore[attr-defined]  # set by casadi/__init__.py, missing from its .pyi
    }


def store_model(
    s: Session,
    result: TrainingResult,
    *,
    campaign_id: int,
    iteration_id: int,
    version: int,
    pool_version_id: int,
    parent_model_id: int | None,
    surrogate_config_version_id: int | None,
    seed: int,
    lineage: dict[str, Any] | None = None,
) -> ModelVersion:
    from alcove.science.surrogate.artifact import artifact_dict

    model = result.model
    weights = {
        f"{'' if i == 0 else f'member{i}.'}{k}.{n}": p.detach().double().numpy()
        for i, member in enumerate(model.members)
        for k, net in (("force", member.force_net), ("moment", member.moment_net))
        for n, p in net.state_dict().items()
    }
    weights_sha = put_arrays(s, weights)
    doc = artifact_dict(
        model,
        {
            **(lineage or {}),
            "campaign_id": campaign_id,
            "iteration": version,
            "pool_version_id": pool_version_id,
            "parent_model_id": parent_model_id,
        },
    )
    artifact_sha = put_bytes(s, json.dumps(doc, sort_keys=True).encode(), ARTIFACT_MEDIA_TYPE)
    m = result.metrics
    mv = ModelVersion(
        campaign_id=campaign_id,
        iteration_id=iteration_id,
        version=version,
        pool_version_id=pool_version_id,
        parent_model_id=parent_model_id,
        surrogate_config_version_id=surrogate_config_version_id,
        seed=int(seed),
        architecture={
            "force": doc["networks"]["force"]["hidden"],
            "moment": doc["networks"]["moment"]["hidden"],
            "activation": {"force": model.force_net.activation, "moment": model.moment_net.activation},
            "dtype": model.config.dtype,
            "ensemble_size": model.ensemble_size,
            "output": model.config.architecture,
            "features": model.config.features,
            "normal_force": model.config.normal_force,
            "inputs": list(model.config.input_names),
        },
        normalisation=doc["normalization"]["input"],
        training_config=model.config.model_dump(mode="json"),
        training_metrics={**m.to_dict(), "test_sets": result.split.test_sets, "history": result.history},
        test_force_rmse=m.rmse["force"]["test"],
        test_moment_rmse=m.rmse["moment"]["test"],
        epochs=max(m.epochs.values()) if m.epochs else None,
        train_wall_time_s=m.wall_time_s,
        weights_sha256=weights_sha,
        artifact_sha256=artifact_sha,
        code_version=code_version(),
        library_versions=library_versions(),
    )
    s.add(mv)
    s.flush()
    with _lock:
        _models[artifact_sha] = model
    return mv


def software_versions() -> dict[str, Any]:
    """Code and library versions recorded with every iteration (and every model version)."""
    return {"code_version": code_version(), "library_versions": library_versions()}


def artifact_document(s: Session, mv: ModelVersion) -> dict[str, Any]:
    if mv.artifact_sha256 is None:
        raise ValueError(f"model version {mv.id} has no artifact")
    document: dict[str, Any] = json.loads(get_bytes(s, mv.artifact_sha256))  # the JSON object store_model wrote
    return document


def load_model(s: Session, mv: ModelVersion) -> SurrogateModel:
    """The trained model of a version (cached per process: artifacts are immutable)."""
    from alcove.science.surrogate.artifact import model_from_dict

    key = mv.artifact_sha256 or ""
    with _lock:
        got = _models.get(key)
    if got is not None:
        return got
    model = model_from_dict(artifact_document(s, mv))
    with _lock:
        _models[key] = model
    return model


def model_artifact_bytes(s: Session, mv: ModelVersion) -> bytes:
    """A zip of the self-contained artifact folder (surrogate.json, force.pt, moment.pt) with the
    portable exports (``*.casadi``, ``*.onnx``, docs/exports.md)."""
    from alcove.science.surrogate.artifact import save_artifact

    model = load_model(s, mv)
    doc = artifact_document(s, mv)
    with tempfile.TemporaryDirectory() as tmp:
        root = save_artifact(model, Path(tmp) / "model", lineage=doc.get("lineage"), exports=True)
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
            for p in sorted(root.iterdir()):
                zf.write(p, p.name)
        return buf.getvalue()


# ----------------------------------------------------------------------------- a campaign's model versions


def campaign_versions(s: Session, campaign_id: int) -> list[ModelVersionRead]:
    """The model versions a campaign trained, with their lineage."""
    return [ModelVersionRead.model_validate(m) for m in repo.own_versions(s, campaign_id)]


def campaign_version(s: Session, campaign_id: int, version: int) -> ModelVersion:
    """Model version ``version`` of a campaign (a fork's early versions are its source's)."""
    mv = repo.version_of(s, campaign_id, version)
    if mv is None:
        raise NotFound("model version", message=f"campaign {campaign_id} has no model version {version}")
    return mv
