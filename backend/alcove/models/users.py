"""Users, API tokens and sharing."""

from __future__ import annotations

import hashlib
import secrets
from datetime import datetime
from typing import TYPE_CHECKING

import sqlalchemy as sa
from sqlalchemy.orm import Mapped, mapped_column, relationship

from alcove.models.base import Base, Role, SharePermission, TimestampMixin, TokenKind, enum_check, utcnow

if TYPE_CHECKING:
    from pwdlib import PasswordHash

    from alcove.models.campaigns import Campaign
    from alcove.models.definitions import OracleDefinition, SurrogateConfigDefinition, TaskDefinition

_password_hasher: PasswordHash | None = None


def password_hasher() -> PasswordHash:
    """The argon2 hasher (pwdlib's recommended parameters)."""
    global _password_hasher
    if _password_hasher is None:
        from pwdlib import PasswordHash

        _password_hasher = PasswordHash.recommended()
    return _password_hasher


def hash_password(password: str) -> str:
    return password_hasher().hash(password)


def verify_password(password: str, password_hash: str) -> tuple[bool, str | None]:
    """Return (valid, new_hash); new_hash is set when the stored hash should be upgraded."""
    return password_hasher().verify_and_update(password, password_hash)


TOKEN_PREFIX = "alc_"


def new_token_secret() -> str:
    """A fresh bearer token (shown to the user once; only its hash is stored)."""
    return TOKEN_PREFIX + secrets.token_urlsafe(32)


def hash_token(token: str) -> str:
    """SHA-256 hex of a bearer token. Tokens are 256-bit random, so a fast hash is right."""
    return hashlib.sha256(token.encode()).hexdigest()


class User(TimestampMixin, Base):
    __tablename__ = "users"
    __table_args__ = (enum_check("role", Role),)

    id: Mapped[int] = mapped_column(primary_key=True)
    email: Mapped[str] = mapped_column(sa.String(320), unique=True, comment="stored lower-case")
    display_name: Mapped[str] = mapped_column(sa.String(200), default="", server_default="")
    password_hash: Mapped[str | None] = mapped_column(
        sa.String(255), comment="argon2 (pwdlib); NULL = no password login"
    )
    role: Mapped[str] = mapped_column(sa.String(16), default=Role.member.value, server_default=Role.member.value)
    is_active: Mapped[bool] = mapped_column(default=True, server_default=sa.true())
    last_login_at: Mapped[datetime | None]

    tokens: Mapped[list[ApiToken]] = relationship(
        back_populates="user", cascade="all, delete-orphan", passive_deletes=True
    )

    @property
    def is_admin(self) -> bool:
        return self.role == Role.admin.value

    def set_password(self, password: str) -> None:
        self.password_hash = hash_password(password)

    def check_password(self, password: str) -> bool:
        """Verify, upgrading the stored hash in place if pwdlib asks for it."""
        if not self.password_hash:
            return False
        ok, new_hash = verify_password(password, self.password_hash)
        if ok and new_hash:
            self.password_hash = new_hash
        return ok


class ApiToken(Base):
    """A bearer token. Only ``token_hash`` (SHA-256) is stored; ``token_prefix`` is for display."""

    __tablename__ = "api_tokens"
    __table_args__ = (enum_check("kind", TokenKind),)

    id: Mapped[int] = mapped_column(primary_key=True)
    user_id: Mapped[int] = mapped_column(sa.ForeignKey("users.id", ondelete="CASCADE"), index=True)
    kind: Mapped[str] = mapped_column(sa.String(16), default=TokenKind.personal.value)
    name: Mapped[str] = mapped_column(sa.String(200), default="", server_default="")
    token_prefix: Mapped[str] = mapped_column(sa.String(16))
    token_hash: Mapped[str] = mapped_column(sa.String(64), unique=True)
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())
    last_used_at: Mapped[datetime | None]
    expires_at: Mapped[datetime | None]
    revoked_at: Mapped[datetime | None]

    user: Mapped[User] = relationship(back_populates="tokens")

    @classmethod
    def issue(
        cls, user: User, *, kind: TokenKind = TokenKind.personal, name: str = "", expires_at: datetime | None = None
    ) -> tuple[ApiToken, str]:
        """Create a token row for ``user`` and return it with the plaintext secret (show once)."""
        secret = new_token_secret()
        row = cls(
            user=user,
            kind=kind.value,
            name=name,
            token_prefix=secret[: len(TOKEN_PREFIX) + 6],
            token_hash=hash_token(secret),
            expires_at=expires_at,
        )
        return row, secret

    def is_valid(self, now: datetime | None = None) -> bool:
        now = now or utcnow()
        return self.revoked_at is None and (self.expires_at is None or self.expires_at > now)


class Share(Base):
    """Grants ``user_id`` access to exactly one object owned by someone else.

    One nullable foreign key per shareable table (exactly one is set), so shares are
    deleted with their object and the database checks the reference.

    A share to an e-mail that no account has is an invitation: ``email`` is set and
    ``user_id`` is NULL (it grants nothing) until an account with that e-mail is created,
    which then gets it. Sharing answers alike either way, so it does not tell a member
    whether an address has an account.
    """

    __tablename__ = "shares"
    __table_args__ = (
        sa.CheckConstraint(
            "(CASE WHEN task_definition_id IS NULL THEN 0 ELSE 1 END)"
            " + (CASE WHEN oracle_definition_id IS NULL THEN 0 ELSE 1 END)"
            " + (CASE WHEN surrogate_config_id IS NULL THEN 0 ELSE 1 END)"
            " + (CASE WHEN campaign_id IS NULL THEN 0 ELSE 1 END) = 1",
            name="exactly_one_object",
        ),
        enum_check("permission", SharePermission),
        sa.UniqueConstraint("user_id", "task_definition_id"),
        sa.UniqueConstraint("user_id", "oracle_definition_id"),
        sa.UniqueConstraint("user_id", "surrogate_config_id"),
        sa.UniqueConstraint("user_id", "campaign_id"),
        sa.CheckConstraint("(user_id IS NULL) <> (email IS NULL)", name="grantee_or_invited_email"),
        sa.UniqueConstraint("email", "task_definition_id"),
        sa.UniqueConstraint("email", "oracle_definition_id"),
        sa.UniqueConstraint("email", "surrogate_config_id"),
        sa.UniqueConstraint("email", "campaign_id"),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    user_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("users.id", ondelete="CASCADE"), index=True, comment="grantee; NULL while an invitation"
    )
    email: Mapped[str | None] = mapped_column(
        sa.String(320), index=True, comment="invited e-mail (lower-case) that no account has yet; else NULL"
    )
    permission: Mapped[str] = mapped_column(
        sa.String(8), default=SharePermission.view.value, server_default=SharePermission.view.value
    )
    task_definition_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("task_definitions.id", ondelete="CASCADE"), index=True
    )
    oracle_definition_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("oracle_definitions.id", ondelete="CASCADE"), index=True
    )
    surrogate_config_id: Mapped[int | None] = mapped_column(
        sa.ForeignKey("surrogate_configs.id", ondelete="CASCADE"), index=True
    )
    campaign_id: Mapped[int | None] = mapped_column(sa.ForeignKey("campaigns.id", ondelete="CASCADE"), index=True)
    created_by_id: Mapped[int | None] = mapped_column(sa.ForeignKey("users.id", ondelete="SET NULL"))
    created_at: Mapped[datetime] = mapped_column(default=utcnow, server_default=sa.func.now())

    user: Mapped[User | None] = relationship(foreign_keys=[user_id])
    task_definition: Mapped[TaskDefinition | None] = relationship()
    oracle_definition: Mapped[OracleDefinition | None] = relationship()
    surrogate_config: Mapped[SurrogateConfigDefinition | None] = relationship()
    campaign: Mapped[Campaign | None] = relationship()
