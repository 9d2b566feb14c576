"""Queries on users, tokens and shares."""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from sqlalchemy.orm import InstrumentedAttribute, Session

from alcove.models import ApiToken, JobLimits, Role, Share, User, hash_token


def user_by_email(session: Session, email: str) -> User | None:
    return session.scalar(sa.select(User).where(User.email == email.strip().lower()))


def user_by_id(session: Session, user_id: int) -> User | None:
    return session.get(User, user_id)


def list_users(session: Session) -> Sequence[User]:
    return session.scalars(sa.select(User).order_by(User.id)).all()


def token_with_user(session: Session, secret: str) -> tuple[ApiToken, User] | None:
    row = session.execute(
        sa.select(ApiToken, User)
        .join(User, ApiToken.user_id == User.id)
        .where(ApiToken.token_hash == hash_token(secret))
    ).first()
    return (row[0], row[1]) if row else None


def list_tokens(session: Session, user: User, *, include_sessions: bool = False) -> Sequence[ApiToken]:
    q = sa.select(ApiToken).where(ApiToken.user_id == user.id)
    if not include_sessions:
        q = q.where(ApiToken.kind == "personal")
    return session.scalars(q.order_by(ApiToken.id)).all()


def shares_of(
    session: Session, column: InstrumentedAttribute[int | None], object_id: int
) -> Sequence[tuple[Share, str]]:
    """The shares of one object with the grantee's e-mail (the invited e-mail for an invitation)."""
    return session.execute(
        sa.select(Share, sa.func.coalesce(User.email, Share.email))
        .outerjoin(User, Share.user_id == User.id)
        .where(column == object_id)
        .order_by(Share.id)
    ).all()


def first_admin(session: Session) -> User | None:
    """The administrator with the smallest id."""
    q = sa.select(User).where(User.role == Role.admin.value).order_by(User.id).limit(1)
    return session.scalar(q)


def default_job_limits(session: Session) -> JobLimits | None:
    """The members' default limits (the row without a user)."""
    return session.scalar(sa.select(JobLimits).where(JobLimits.user_id.is_(None)).order_by(JobLimits.id).limit(1))


def own_job_limits(session: Session, user_id: int) -> JobLimits | None:
    return session.scalar(sa.select(JobLimits).where(JobLimits.user_id == user_id))


def lock_user(session: Session, user_id: int) -> None:
    """Hold the user's row until the transaction ends: decisions about their running work
    (start one more campaign or let it wait) are taken one at a time."""
    session.execute(sa.select(User.id).where(User.id == user_id).with_for_update())
