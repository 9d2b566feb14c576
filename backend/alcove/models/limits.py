"""Job limits: how much work a user may ask of the shared workers.

One row without a user holds the defaults every member has; a row with a user holds that
user's own limits (all of them: an administrator's edit starts from the defaults). A NULL
limit is no limit. Administrators are bound only by a row of their own.
"""

from __future__ import annotations

from datetime import datetime

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, mapped_column

from alcove.models.base import Base, utcnow

#: the limits, in the order the API and the command line show them, with their defaults
DEFAULT_JOB_LIMITS: dict[str, int | None] = {
    "max_running_campaigns": 4,
    "max_preliminary_samples": 100_000,
    "max_ocp_intervals": 2_000,
    "max_ensemble_size": 16,
    "max_hidden_layers": 8,
    "max_layer_width": 512,
    "max_epochs": 10_000,
}


class JobLimits(Base):
    __tablename__ = "job_limits"

    id: Mapped[int] = mapped_column(primary_key=True)
    user_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("users.id", ondelete="CASCADE"), unique=True, comment="NULL: the defaults of every member"
    )
    max_running_campaigns: Mapped[int | None] = mapped_column(
        comment="campaigns running at once (more wait in 'queued' until one ends); NULL: no limit"
    )
    max_preliminary_samples: Mapped[int | None] = mapped_column(comment="preliminary.samples; NULL: no limit")
    max_ocp_intervals: Mapped[int | None] = mapped_column(
        comment="DMOCC intervals per phase (settings.ocp_intervals, the task's, a preview's); NULL: no limit"
    )
    max_ensemble_size: Mapped[int | None] = mapped_column(comment="surrogate ensemble_size; NULL: no limit")
    max_hidden_layers: Mapped[int | None] = mapped_column(comment="hidden layers of one net; NULL: no limit")
    max_layer_width: Mapped[int | None] = mapped_column(comment="units of one hidden layer; NULL: no limit")
    max_epochs: Mapped[int | None] = mapped_column(comment="max_epochs and warm_max_epochs; NULL: no limit")
    updated_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
