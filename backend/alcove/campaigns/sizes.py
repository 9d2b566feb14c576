"""A campaign's size against its owner's job limits (:mod:`alcove.users.limits`): checked at
create, at every settings edit and at start (limits may have changed since), a 422 naming the
field, its value and the limit."""

from __future__ import annotations

from sqlalchemy.orm import Session

from alcove.campaigns.config import CampaignConfig, PreliminaryConfig, RunSettings
from alcove.errors import FieldError
from alcove.models import SurrogateConfigVersion, TaskVersion, User
from alcove.users.limits import Size, check_sizes, limits_of, size_problems, surrogate_sizes


def campaign_sizes(
    s: Session,
    preliminary: PreliminaryConfig | None,
    settings: RunSettings | None,
    task_version_id: int | None,
    surrogate_config_version_id: int | None,
) -> list[Size]:
    """``(field, value, limit name)`` of everything a campaign asks of the workers (a part left
    out, None, is not sized)."""
    sizes: list[Size] = []
    if preliminary is not None and not preliminary.dataset_ids:
        sizes.append(("preliminary.samples", preliminary.samples, "max_preliminary_samples"))
    if settings is not None and settings.ocp_intervals is not None:
        sizes.append(("settings.ocp_intervals", settings.ocp_intervals, "max_ocp_intervals"))
    elif settings is not None and task_version_id is not None:
        task = s.get(TaskVersion, task_version_id)
        phases = (task.spec.get("phases") or []) if task is not None else []
        per_phase = [int(ph.get("intervals") or 0) for ph in phases if isinstance(ph, dict)]
        if per_phase:
            # the task's intervals apply: the field to set is settings.ocp_intervals
            sizes.append(("settings.ocp_intervals", max(per_phase), "max_ocp_intervals", "the task's, per phase"))
    scv = s.get(SurrogateConfigVersion, surrogate_config_version_id) if surrogate_config_version_id else None
    if scv is not None:
        sizes += surrogate_sizes(scv.spec, prefix="surrogate_config")
    return sizes


def campaign_size_problems(
    s: Session,
    user: User,
    preliminary: PreliminaryConfig | None,
    settings: RunSettings | None,
    task_version_id: int | None,
    surrogate_config_version_id: int | None,
) -> list[FieldError]:
    """What of a new campaign is above the limits of ``user`` (its owner)."""
    sizes = campaign_sizes(s, preliminary, settings, task_version_id, surrogate_config_version_id)
    return size_problems(limits_of(s, user), sizes)


def check_campaign_sizes(
    s: Session, owner_id: int, cfg: CampaignConfig, task_version_id: int, surrogate_config_version_id: int
) -> None:
    """Refuse (422) a campaign above its owner's size limits."""
    sizes = campaign_sizes(s, cfg.preliminary, cfg.settings, task_version_id, surrogate_config_version_id)
    check_sizes(s, owner_id, sizes)
