"""Job limits: read and set them, and refuse work above them.

A member has the members' defaults unless an administrator gave them limits of their own; an
administrator has no limit unless given limits of their own. Size limits refuse a request with a
422 naming the field, its value and the limit; the running-campaigns limit makes a campaign wait
(:mod:`alcove.campaigns.machine.admission`).
"""

from __future__ import annotations

from collections.abc import Iterable

from sqlalchemy.orm import Session

from alcove.errors import FieldError, InvalidInput
from alcove.models import DEFAULT_JOB_LIMITS, JobLimits, User, utcnow
from alcove.users import repository as repo
from alcove.users.schemas import JobLimitsOut, JobLimitsUpdate

LIMIT_NAMES = tuple(DEFAULT_JOB_LIMITS)


def _values(row: JobLimits | None) -> dict[str, int | None]:
    if row is None:
        return dict.fromkeys(LIMIT_NAMES)
    return {name: getattr(row, name) for name in LIMIT_NAMES}


def defaults(session: Session) -> JobLimitsOut:
    return JobLimitsOut(**_values(repo.default_job_limits(session)), source="defaults")


def limits_of(session: Session, user: User) -> JobLimitsOut:
    """The limits that bind ``user``."""
    own = repo.own_job_limits(session, user.id)
    if own is not None:
        return JobLimitsOut(**_values(own), source="own")
    if user.is_admin:
        return JobLimitsOut(**_values(None), source="none")
    return defaults(session)


def limits_of_id(session: Session, user_id: int) -> JobLimitsOut:
    user = session.get(User, user_id)
    assert user is not None, f"no user {user_id}"
    return limits_of(session, user)


def set_defaults(session: Session, update: JobLimitsUpdate) -> JobLimitsOut:
    row = repo.default_job_limits(session)
    if row is None:
        row = JobLimits(user_id=None, **DEFAULT_JOB_LIMITS)
        session.add(row)
    _apply(row, update)
    session.flush()
    return defaults(session)


def set_own(session: Session, user: User, update: JobLimitsUpdate) -> JobLimitsOut:
    """Give ``user`` limits of their own: the limits that bound them until now, changed by ``update``."""
    row = repo.own_job_limits(session, user.id)
    if row is None:
        current = limits_of(session, user)
        row = JobLimits(user_id=user.id, **current.model_dump(include=set(LIMIT_NAMES)))
        session.add(row)
    _apply(row, update)
    session.flush()
    return limits_of(session, user)


def reset_own(session: Session, user: User) -> JobLimitsOut:
    """Drop ``user``'s own limits: the defaults bind them again (an administrator: no limit)."""
    row = repo.own_job_limits(session, user.id)
    if row is not None:
        session.delete(row)
        session.flush()
    return limits_of(session, user)


def _apply(row: JobLimits, update: JobLimitsUpdate) -> None:
    for name in update.model_fields_set:
        setattr(row, name, getattr(update, name))
    row.updated_at = utcnow()


#: ``(field, value, limit name)``, or with a fourth item saying where the value comes from
Size = tuple[str, int | None, str] | tuple[str, int | None, str, str]


def size_problems(limits: JobLimitsOut, sizes: Iterable[Size]) -> list[FieldError]:
    """A problem for every size whose value is above its limit."""
    problems = []
    for field, value, name, *source in sizes:
        bound = getattr(limits, name)
        if value is not None and bound is not None and value > bound:
            origin = f" ({source[0]})" if source else ""
            problems.append(
                FieldError(
                    tuple(int(p) if p.isdigit() else p for p in field.split(".")),
                    f"{value}{origin} is above your limit of {bound} ({name}); ask an administrator to raise it",
                    "job_limit",
                )
            )
    return problems


def check_sizes(session: Session, user_id: int, sizes: Iterable[Size]) -> None:
    """Refuse (422) a request whose sizes are above the limits of user ``user_id``."""
    problems = size_problems(limits_of_id(session, user_id), sizes)
    if problems:
        raise InvalidInput(problems)


def surrogate_sizes(spec: dict[str, object], prefix: str = "spec") -> list[Size]:
    """The sized fields of a surrogate config's spec (a dict as stored)."""
    sizes: list[Size] = []

    def whole(value: object) -> int | None:
        return int(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None

    sizes.append((f"{prefix}.ensemble_size", whole(spec.get("ensemble_size")), "max_ensemble_size"))
    sizes.append((f"{prefix}.max_epochs", whole(spec.get("max_epochs")), "max_epochs"))
    sizes.append((f"{prefix}.warm_max_epochs", whole(spec.get("warm_max_epochs")), "max_epochs"))
    for net in ("force", "moment"):
        network = spec.get(net)
        hidden = network.get("hidden") if isinstance(network, dict) else None
        if isinstance(hidden, (list, tuple)):
            sizes.append((f"{prefix}.{net}.hidden", len(hidden), "max_hidden_layers"))
            widths = [whole(w) for w in hidden]
            widest = max((w for w in widths if w is not None), default=None)
            if widest is not None:
                sizes.append((f"{prefix}.{net}.hidden.{widths.index(widest)}", widest, "max_layer_width"))
    return sizes
