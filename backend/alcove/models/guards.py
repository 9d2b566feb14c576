"""ORM-level guard for immutable rows.

* ``__immutable_columns__`` on a class: these attributes may not change once the row is
  persistent (pool versions, blobs, datasets, model versions, campaign config versions).
* ``__immutable_when_locked__``: the same, but only once ``locked_at`` was set (task,
  oracle and surrogate-config versions become immutable when first used).

Bulk ``UPDATE`` statements bypass the ORM; the services do not issue them on these tables.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import event, inspect
from sqlalchemy.orm import Session


class ImmutableRowError(RuntimeError):
    """An attempt to modify a row that is immutable (create a new version instead)."""


def _changed(obj: Any, attrs: tuple[str, ...]) -> list[str]:
    state = inspect(obj)
    return [a for a in attrs if a in state.attrs and state.attrs[a].history.has_changes()]


@event.listens_for(Session, "before_flush")
def _refuse_changes_to_immutable_rows(session: Session, flush_context: Any, instances: Any) -> None:
    for obj in session.dirty:
        always = getattr(obj, "__immutable_columns__", None)
        if always:
            changed = _changed(obj, always)
            if changed:
                raise ImmutableRowError(f"{type(obj).__name__} is immutable; attempted to change {', '.join(changed)}")
        when_locked = getattr(obj, "__immutable_when_locked__", None)
        if when_locked:
            hist = inspect(obj).attrs["locked_at"].history
            was_locked = (
                bool(hist.deleted) and hist.deleted[0] is not None if hist.has_changes() else obj.locked_at is not None
            )
            if was_locked:
                changed = _changed(obj, when_locked)
                if changed:
                    raise ImmutableRowError(
                        f"{type(obj).__name__} {getattr(obj, 'version', '?')} is used by a campaign and immutable; "
                        f"attempted to change {', '.join(changed)} (create a new version)"
                    )
