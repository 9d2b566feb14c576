"""A campaign's whole output in one folder or zip: settings and config versions, metrics
(CSV and JSON), iterations, pool versions, model artifacts, curves."""

from __future__ import annotations

import io
import json
import zipfile
from pathlib import Path

from sqlalchemy.orm import Session

from alcove.campaigns import repository as repo
from alcove.campaigns.config import config_from_version
from alcove.campaigns.views.detail import get_detail, list_iterations, metrics_series
from alcove.campaigns.views.validation import validation_files
from alcove.db.arrays import get_bytes
from alcove.models import ModelVersion
from alcove.pool import repository as pool_repo
from alcove.pool import service as pool_service
from alcove.surrogates import repository as surrogates_repo
from alcove.surrogates import service as surrogates_service
from alcove.surrogates.artifact_zips import stored_zip_paths

#: The columns of ``metrics.csv``.
METRICS_COLUMNS = [
    "iteration_index",
    "force_rmse",
    "moment_rmse",
    "force_rmse_contact",
    "moment_rmse_contact",
    "calibration",
    "metrics_definition",
    "force_max_error",
    "moment_max_error",
    "ocp_success",
    "ocp_status",
    "ocp_iterations",
    "ocp_cost",
    "ocp_wall_time_s",
    "ocp_trusted",
    "oracle_wall_time_s",
    "train_wall_time_s",
    "n_pool_samples",
    "model_version_id",
    "dataset_id",
    "validation_force_rmse",
    "validation_moment_rmse",
    "validation_calibration",
    "validation_calibration_recorded",
]


def export_campaign(
    s: Session, campaign_id: int, folder: str | Path | None = None, *, pool_format: str = "parquet", models: bool = True
) -> bytes | Path:
    """Everything a campaign produced: ``campaign.json`` (settings, status, lineage),
    ``metrics.csv``/``metrics.json``, ``iterations.json``, ``pool/version-KKKK.<fmt>``,
    ``models/model-KKKK.zip``, ``curves/iteration-KKKK.npz``, ``validation/suite.json`` and
    ``validation/motion-MM.csv`` (the held-out suite and each model version's error on it).
    Written into ``folder`` (returned), or as zip bytes when ``folder`` is None."""
    c = repo.get_campaign(s, campaign_id)
    files: dict[str, bytes] = {}
    detail = get_detail(s, campaign_id)
    files["campaign.json"] = json.dumps(
        {
            "campaign": detail.campaign.model_dump(mode="json"),
            "config": detail.config.model_dump(mode="json"),
            "config_versions": [
                {
                    "version": v.version,
                    "note": v.note,
                    "created_at": v.created_at.isoformat(),
                    **config_from_version(v).model_dump(mode="json"),
                }
                for v in repo.config_versions(s, c.id)
            ],
            "pool_versions": [p.model_dump(mode="json") for p in pool_service.campaign_versions(s, c.id)],
            "model_versions": [m.model_dump(mode="json") for m in surrogates_service.campaign_versions(s, c.id)],
            "validation_suite": detail.validation.model_dump(mode="json") if detail.validation else None,
        },
        indent=1,
    ).encode()
    series = metrics_series(s, c.id)
    files["metrics.json"] = json.dumps([m.model_dump(mode="json") for m in series], indent=1).encode()
    cols = METRICS_COLUMNS
    lines = [",".join(cols)] + [
        ",".join("" if getattr(m, k) is None else str(getattr(m, k)) for k in cols) for m in series
    ]
    files["metrics.csv"] = ("\n".join(lines) + "\n").encode()
    files["iterations.json"] = json.dumps(
        [i.model_dump(mode="json") for i in list_iterations(s, c.id)], indent=1
    ).encode()
    for pv in pool_repo.own_versions(s, c.id):
        files[f"pool/version-{pv.version:04d}.{pool_format}"] = pool_service.pool_version_table(s, pv, pool_format)
    if models:
        for mv in surrogates_repo.own_versions(s, c.id):
            files[f"models/model-{mv.version:04d}.zip"] = surrogates_service.model_artifact_bytes(s, mv)
    for m in repo.metrics_series(s, c.id):
        if m.curves_sha256:
            files[f"curves/iteration-{m.iteration_index:04d}.npz"] = get_bytes(s, m.curves_sha256)
    files.update(validation_files(s, c))
    if folder is None:
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
            for name, data in files.items():
                zf.writestr(f"campaign-{c.id}/{name}", data)
        return buf.getvalue()
    root = Path(folder)
    for name, data in files.items():
        p = root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data)
    return root


def exported_model_versions(s: Session, campaign_id: int) -> list[ModelVersion]:
    """The campaign's own model versions with an artifact: the ``models/`` of its export."""
    return [mv for mv in surrogates_repo.own_versions(s, campaign_id) if mv.artifact_sha256]


def export_zip(s: Session, campaign_id: int, *, pool_format: str = "parquet", models: bool = True) -> bytes:
    """:func:`export_campaign` as zip bytes, the models as their full artifact zips (with the
    TorchScript files), which must be built and stored already (the route builds them first)."""
    data = export_campaign(s, campaign_id, pool_format=pool_format, models=False)
    assert isinstance(data, bytes)
    versions = exported_model_versions(s, campaign_id) if models else []
    if not versions:
        return data
    paths = stored_zip_paths(versions)
    buf = io.BytesIO(data)
    with zipfile.ZipFile(buf, "a", zipfile.ZIP_DEFLATED) as zf:
        for mv in versions:
            zf.write(paths[mv.id], f"campaign-{campaign_id}/models/model-{mv.version:04d}.zip")
    return buf.getvalue()
