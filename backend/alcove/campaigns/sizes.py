"""A campaign's size against its owner's job limits (:mod:`alcove.users.limits`): checked at
create, at every settings edit and at start (limits may have changed since), a 422 naming the
field, its value and the limit."""

from __future__ import annotations

from sqlalchemy.orm import Session

from alcove.campaigns.schemas import CampaignConfig
from alcove.models import SurrogateConfigVersion, TaskVersion
from alcove.users.limits import check_sizes, surrogate_sizes


def campaign_sizes(
    s: Session, cfg: CampaignConfig, task_version_id: int, surrogate_config_version_id: int
) -> list[tuple[str, int | None, str]]:
    """``(field, value, limit name)`` of everything a campaign with ``cfg`` asks of the workers."""
    sizes: list[tuple[str, int | None, str]] = []
    if not cfg.preliminary.dataset_ids:
        sizes.append(("preliminary.samples", cfg.preliminary.samples, "max_preliminary_samples"))
    if cfg.settings.ocp_intervals is not None:
        sizes.append(("settings.ocp_intervals", cfg.settings.ocp_intervals, "max_ocp_intervals"))
    else:
        task = s.get(TaskVersion, task_version_id)
        phases = (task.spec.get("phases") or []) if task is not None else []
        per_phase = [int(ph.get("intervals") or 0) for ph in phases if isinstance(ph, dict)]
        if per_phase:
            # the task's intervals apply: the field to set is settings.ocp_intervals
            sizes.append(("settings.ocp_intervals", max(per_phase), "max_ocp_intervals"))
    scv = s.get(SurrogateConfigVersion, surrogate_config_version_id)
    if scv is not None:
        sizes += surrogate_sizes(scv.spec, prefix="surrogate_config")
    return sizes


def check_campaign_sizes(
    s: Session, owner_id: int, cfg: CampaignConfig, task_version_id: int, surrogate_config_version_id: int
) -> None:
    """Refuse (422) a campaign above its owner's size limits."""
    check_sizes(s, owner_id, campaign_sizes(s, cfg, task_version_id, surrogate_config_version_id))
