"""First-start bootstrap: the first admin account."""

from __future__ import annotations

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.models import Role, User


def ensure_first_admin(session: Session, email: str, password: str) -> User | None:
    """Create an admin from ``email``/``password`` if no admin exists. Returns the new user or None."""
    if session.scalar(sa.select(sa.func.count()).select_from(User).where(User.role == Role.admin.value)):
        return None
    email = email.strip().lower()
    user = session.scalar(sa.select(User).where(User.email == email))
    if user is None:
        user = User(email=email, display_name="Administrator", role=Role.admin.value)
        user.set_password(password)
        session.add(user)
    else:  # an existing member with that address becomes the admin; its password is kept
        user.role = Role.admin.value
    session.flush()
    return user
