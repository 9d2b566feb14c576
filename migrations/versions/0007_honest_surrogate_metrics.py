"""honest surrogate metrics: force/moment RMSE of the error vector, in-contact variants, calibration

Before, ``force_rmse`` was ``sqrt(mean over samples and the 3 components of e^2)``; now it is the
root mean square of the error vector's norm, ``sqrt(mean over samples of |e|^2)`` (the moment
likewise; see docs/concepts.md). The new value is exactly ``sqrt(3)`` times the old one, so stored
figures are converted, not mixed:

* ``iteration_metrics.force_rmse``, ``moment_rmse`` and ``extra.model_test_rmse``;
* ``model_versions.test_force_rmse``, ``test_moment_rmse`` and ``training_metrics.rmse``
  (which gets ``rmse_definition: "vector"``);
* the stopping rules ``target_force_rmse`` / ``target_moment_rmse`` of stored campaign configs,
  so that a campaign stops where it stopped before.

New columns ``force_rmse_contact``, ``moment_rmse_contact`` (the same over the samples with
nonzero oracle force) are recomputed from the stored curves (``f_true``, ``f_pred``) where they
exist; ``calibration`` (ensembles only) stays null for old rows (one model, no spread).
``metrics_definition`` says which definition a row follows ("vector" for every row after this
migration). Downgrade converts back and drops the columns.

Revision ID: 0007
Revises: 0006
Create Date: 2026-12-02 05:30:00
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import postgresql

revision: str = "0007"
down_revision: str | Sequence[str] | None = "0006"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

JSON = sa.JSON().with_variant(postgresql.JSONB(), "postgresql")
FACTOR = math.sqrt(3.0)  # vector RMSE / old component-mean RMSE, exact for 3 components

metrics = sa.table(
    "iteration_metrics",
    sa.column("id", sa.Integer),
    sa.column("force_rmse", sa.Float),
    sa.column("moment_rmse", sa.Float),
    sa.column("force_rmse_contact", sa.Float),
    sa.column("moment_rmse_contact", sa.Float),
    sa.column("extra", JSON),
    sa.column("curves_sha256", sa.String),
)
models = sa.table(
    "model_versions",
    sa.column("id", sa.Integer),
    sa.column("test_force_rmse", sa.Float),
    sa.column("test_moment_rmse", sa.Float),
    sa.column("training_metrics", JSON),
)
configs = sa.table("campaign_config_versions", sa.column("id", sa.Integer), sa.column("stopping_rules", JSON))
blobs = sa.table("blobs", sa.column("sha256", sa.String), sa.column("data", sa.LargeBinary))


def _scale(v: Any, f: float) -> Any:
    return v * f if isinstance(v, (int, float)) and not isinstance(v, bool) else v


def _contact_rmse(data: bytes) -> tuple[float | None, float | None]:
    """The in-contact force and moment RMSE (vector definition) from a curves blob."""
    with np.load(io.BytesIO(data), allow_pickle=False) as npz:
        if "f_true" not in npz.files or "f_pred" not in npz.files:
            return None, None
        true, pred = npz["f_true"], npz["f_pred"]
    if true.ndim != 2 or true.shape[1] != 6 or pred.shape != true.shape:
        return None, None
    contact = np.linalg.norm(true[:, :3], axis=1) > 0
    if not contact.any():
        return None, None
    e = pred[contact] - true[contact]
    return float(np.sqrt(np.mean(np.sum(e[:, :3] ** 2, 1)))), float(np.sqrt(np.mean(np.sum(e[:, 3:] ** 2, 1))))


def _convert(f: float, recompute_contact: bool) -> None:
    conn = op.get_bind()
    rows = conn.execute(
        sa.select(metrics.c.id, metrics.c.force_rmse, metrics.c.moment_rmse, metrics.c.extra, metrics.c.curves_sha256)
    ).all()
    for row_id, frmse, mrmse, extra, curves in rows:
        extra = dict(extra or {})
        if isinstance(extra.get("model_test_rmse"), dict):
            extra["model_test_rmse"] = {k: _scale(v, f) for k, v in extra["model_test_rmse"].items()}
        values: dict[str, Any] = {"force_rmse": _scale(frmse, f), "moment_rmse": _scale(mrmse, f), "extra": extra}
        if recompute_contact and curves is not None:
            data = conn.execute(sa.select(blobs.c.data).where(blobs.c.sha256 == curves)).scalar()
            if data is not None:
                values["force_rmse_contact"], values["moment_rmse_contact"] = _contact_rmse(bytes(data))
        conn.execute(sa.update(metrics).where(metrics.c.id == row_id).values(**values))
    for row_id, tf, tm, tmetrics in conn.execute(
        sa.select(models.c.id, models.c.test_force_rmse, models.c.test_moment_rmse, models.c.training_metrics)
    ).all():
        tmetrics = dict(tmetrics or {})
        if isinstance(tmetrics.get("rmse"), dict):
            tmetrics["rmse"] = {
                net: ({s: _scale(v, f) for s, v in splits.items()} if isinstance(splits, dict) else splits)
                for net, splits in tmetrics["rmse"].items()
            }
        if f > 1:
            tmetrics["rmse_definition"] = "vector"
        else:
            tmetrics.pop("rmse_definition", None)
        conn.execute(
            sa.update(models)
            .where(models.c.id == row_id)
            .values(test_force_rmse=_scale(tf, f), test_moment_rmse=_scale(tm, f), training_metrics=tmetrics)
        )
    _rewrite_rules(lambda rules: _scale_targets(rules, f))


def _scale_targets(rules: dict[str, Any], f: float) -> dict[str, Any] | None:
    keys = [k for k in ("target_force_rmse", "target_moment_rmse") if rules.get(k) is not None]
    if not keys:
        return None
    return {**rules, **{k: _scale(rules[k], f) for k in keys}}


def _rewrite_rules(change: Callable[[dict[str, Any]], dict[str, Any] | None]) -> None:
    conn = op.get_bind()
    for row_id, rules in conn.execute(sa.select(configs.c.id, configs.c.stopping_rules)).all():
        new = change(dict(rules or {}))
        if new is not None:
            conn.execute(sa.update(configs).where(configs.c.id == row_id).values(stopping_rules=new))


def upgrade() -> None:
    with op.batch_alter_table("iteration_metrics") as batch:
        batch.add_column(sa.Column("force_rmse_contact", sa.Float(), nullable=True, comment="N, samples in contact"))
        batch.add_column(sa.Column("moment_rmse_contact", sa.Float(), nullable=True, comment="N m, samples in contact"))
        batch.add_column(
            sa.Column("calibration", sa.Float(), nullable=True, comment="share of oracle values within mean +- 2 std")
        )
        batch.add_column(
            sa.Column(
                "metrics_definition",
                sa.String(32),
                nullable=False,
                server_default="vector",
                comment="vector: RMSE of the force/moment error vector (docs/concepts.md)",
            )
        )
    _convert(FACTOR, recompute_contact=True)


def downgrade() -> None:
    _convert(1.0 / FACTOR, recompute_contact=False)
    with op.batch_alter_table("iteration_metrics") as batch:
        batch.drop_column("metrics_definition")
        batch.drop_column("calibration")
        batch.drop_column("moment_rmse_contact")
        batch.drop_column("force_rmse_contact")
