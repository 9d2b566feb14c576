"""Login, bearer tokens, user administration and sharing. Services never commit.

Login throttling (growing delays per account and client, a limit per client address) is the
router's, in :mod:`alcove.users.ratelimit`: it keys on the e-mail as typed, whether or not an
account has it, so that nothing here has to count failures."""

from __future__ import annotations

import threading
import time
from datetime import timedelta
from typing import TypeVar

import sqlalchemy as sa
from cachetools import TLRUCache
from sqlalchemy.orm import Session, make_transient_to_detached
from sqlalchemy.orm.attributes import manager_of_class

from alcove.errors import AuthenticationFailed, Conflict, InvalidInput, NotFound, PermissionDenied
from alcove.models import ApiToken, Role, Share, TokenKind, User, hash_password, hash_token, utcnow
from alcove.users import repository as repo
from alcove.users import revocation
from alcove.users.access import LABEL, OBJECT_TYPES, SHARE_COLUMN, get_for
from alcove.users.schemas import ShareCreate, ShareOut, UserCreate, UserUpdate

T = TypeVar("T", ApiToken, User)

#: Lifetime of a token issued by password login.
SESSION_TOKEN_LIFETIME = timedelta(hours=12)
#: ``last_used_at`` of a token is refreshed at most this often (no write per request).
LAST_USED_RESOLUTION = timedelta(minutes=1)

_DUMMY_HASH: list[str] = []
_dummy_lock = threading.Lock()


def dummy_password_hash() -> str:
    """A hash made with the same hasher and parameters as real ones (made once per process;
    :func:`alcove.app.create_app` makes it at start, so no login pays for it)."""
    if not _DUMMY_HASH:
        with _dummy_lock:
            if not _DUMMY_HASH:
                _DUMMY_HASH.append(hash_password("not-a-real-password"))
    return _DUMMY_HASH[0]


def _burn_a_hash(password: str) -> None:
    """Verify against the dummy hash: an unknown e-mail costs the same password-hash work as
    a wrong password (one argon2 verification)."""
    from alcove.models.users import verify_password

    verify_password(password, dummy_password_hash())


def login(session: Session, email: str, password: str) -> tuple[ApiToken, str]:
    """Check the password and issue a session token. Raises :class:`AuthenticationFailed`
    with the same message for an unknown e-mail, an inactive account and a wrong password,
    after the same work (one argon2 verification, no write)."""
    user = repo.user_by_email(session, email)
    if user is None or not user.is_active or not user.password_hash:
        _burn_a_hash(password)
        raise AuthenticationFailed("wrong e-mail or password")
    if not user.check_password(password):
        raise AuthenticationFailed("wrong e-mail or password")
    now = utcnow()
    user.last_login_at = now
    token, secret = ApiToken.issue(user, kind=TokenKind.session, name="login", expires_at=now + SESSION_TOKEN_LIFETIME)
    session.add(token)
    session.flush()
    return token, secret


class _TokenCache:
    """Recently verified tokens (by hash) for ``ttl_s`` seconds (a ``cachetools.TLRUCache``:
    the time to live is read when an entry is put, least recently used entries go first when
    full), so a polling dashboard does not pay a token lookup per request. Each entry keeps the
    revocation generation (:mod:`alcove.users.revocation`) read before the token was verified,
    and is trusted only while the generation is unchanged: a revocation through any API
    process ends it at once."""

    def __init__(self, ttl_s: float, max_entries: int = 4096) -> None:
        self.ttl_s = ttl_s
        self.max_entries = max_entries
        self._data: TLRUCache[str, tuple[ApiToken, User, int]] = TLRUCache(
            maxsize=max_entries, ttu=lambda _key, _value, now: now + self.ttl_s, timer=time.monotonic
        )
        self._lock = threading.Lock()

    def get(self, key: str) -> tuple[ApiToken, User, int] | None:
        with self._lock:
            return self._data.get(key)

    def put(self, key: str, token: ApiToken, user: User, generation: int = 0) -> None:
        with self._lock:
            self._data[key] = (token, user, generation)

    def drop(self, *, token_id: int | None = None, user_id: int | None = None) -> None:
        with self._lock:
            for key in list(self._data):
                hit = self._data.get(key)
                if hit is not None and (hit[0].id == token_id or hit[1].id == user_id):
                    del self._data[key]

    def clear(self) -> None:
        with self._lock:
            self._data.clear()


#: Seconds a verified token is trusted without a database lookup (per API process), while the
#: revocation generation is unchanged (the limit if a raise of the generation got lost).
TOKEN_CACHE_SECONDS = 5.0
TOKENS = _TokenCache(TOKEN_CACHE_SECONDS)


def cached_authentication(session: Session, secret: str, generation: int | None = None) -> tuple[ApiToken, User] | None:
    """The token and user from the short-lived cache, as fresh detached instances private to
    this request (``session.merge`` them to change them); None when not cached or cached under
    another revocation generation than ``generation`` (read now when not given; None, no
    shared generation: nothing is trusted)."""
    if generation is None:
        generation = revocation.generation().current()
        if generation is None:
            return None
    hit = TOKENS.get(hash_token(secret))
    if hit is not None and hit[2] == generation and hit[0].is_valid():
        return _detached_copy(hit[0]), _detached_copy(hit[1])
    return None


def authenticate(session: Session, secret: str) -> tuple[ApiToken, User] | None:
    """The valid token and its active user, or None (from the cache or the database)."""
    generation = revocation.generation().current()  # before the lookup: a later revocation raises it
    if generation is not None:
        cached = cached_authentication(session, secret, generation)
        if cached is not None:
            return cached
    key = hash_token(secret)
    found = repo.token_with_user(session, secret)
    if found is None:
        return None
    token, user = found
    if not token.is_valid() or not user.is_active:
        return None
    if generation is not None and not needs_touch(token):
        TOKENS.put(key, _detached_copy(token), _detached_copy(user), generation)
    return token, user


_COLUMN_KEYS: dict[type, tuple[str, ...]] = {}


def _detached_copy(obj: T) -> T:
    """A detached instance with the same column values (no relationships loaded)."""
    cls = type(obj)
    keys = _COLUMN_KEYS.get(cls)
    if keys is None:
        keys = _COLUMN_KEYS[cls] = tuple(attr.key for attr in sa.inspect(cls).column_attrs)
    src = obj.__dict__
    copy = manager_of_class(cls).new_instance()
    state = sa.inspect(copy)
    # the values as committed state in one step (what set_committed_value does per key)
    state.dict.update({k: src[k] if k in src else getattr(obj, k) for k in keys})
    state._commit_all(state.dict)
    make_transient_to_detached(copy)
    return copy


def user_of_token(session: Session, token_id: int) -> User | None:
    """The active user whose token ``token_id`` is still valid, read from the database (not the
    verified-token cache): for what outlives a request, such as an open event stream."""
    token = session.get(ApiToken, token_id)
    if token is None or not token.is_valid():
        return None
    user = session.get(User, token.user_id)
    return user if user is not None and user.is_active else None


def needs_touch(token: ApiToken) -> bool:
    return token.last_used_at is None or utcnow() - token.last_used_at > LAST_USED_RESOLUTION


def create_token(session: Session, user: User, name: str, expires_in_days: int | None) -> tuple[ApiToken, str]:
    expires = utcnow() + timedelta(days=expires_in_days) if expires_in_days else None
    token, secret = ApiToken.issue(user, kind=TokenKind.personal, name=name, expires_at=expires)
    session.add(token)
    session.flush()
    return token, secret


def revoke_token(session: Session, user: User, token_id: int) -> ApiToken:
    token = session.get(ApiToken, token_id)
    if token is None or token.user_id != user.id:
        raise NotFound("token", token_id)
    if token.revoked_at is None:
        token.revoked_at = utcnow()
        session.flush()
    TOKENS.drop(token_id=token.id)
    revocation.bump_after_commit(session)
    return token


def revoke(session: Session, token: ApiToken) -> None:
    token = session.merge(token)
    token.revoked_at = utcnow()
    session.flush()
    TOKENS.drop(token_id=token.id)
    revocation.bump_after_commit(session)


# ----------------------------------------------------------------------------- users


def create_user(session: Session, body: UserCreate) -> User:
    if repo.user_by_email(session, body.email) is not None:
        raise Conflict(f"a user with e-mail {body.email} exists")
    user = User(email=body.email, display_name=body.display_name, role=body.role)
    user.set_password(body.password)
    session.add(user)
    session.flush()
    accept_invitations(session, user)
    return user


def get_user(session: Session, user_id: int) -> User:
    user = repo.user_by_id(session, user_id)
    if user is None:
        raise NotFound("user", user_id)
    return user


def update_user(session: Session, admin: User, user_id: int, body: UserUpdate) -> User:
    user = get_user(session, user_id)
    if user.id == admin.id and (body.role == Role.member.value or body.is_active is False):
        raise Conflict("an administrator cannot demote or deactivate themselves")
    if body.display_name is not None:
        user.display_name = body.display_name
    if body.role is not None:
        user.role = body.role
    if body.is_active is not None:
        user.is_active = body.is_active
    if body.password is not None:
        user.set_password(body.password)
        end_tokens(session, user, keep_personal=False)  # a reset shuts out whoever knew the old one
    session.flush()
    TOKENS.drop(user_id=user.id)
    revocation.bump_after_commit(session)  # a role or an activity change too
    return user


def update_me(
    session: Session,
    user: User,
    display_name: str | None,
    new_password: str | None,
    current_password: str | None,
    keep_personal_tokens: bool = False,
) -> User:
    """Change the display name and the password. A new password ends every token of the user
    (the sessions, this request's too, and the personal tokens unless ``keep_personal_tokens``)."""
    if keep_personal_tokens and new_password is None:
        raise InvalidInput.one("keep_personal_tokens", "applies to a password change only: send it with new_password")
    if display_name is not None:
        user.display_name = display_name
    if new_password is not None:
        if not current_password or not user.check_password(current_password):
            raise InvalidInput.one("current_password", "does not match your current password")
        user.set_password(new_password)
        end_tokens(session, user, keep_personal=keep_personal_tokens)
    session.flush()
    TOKENS.drop(user_id=user.id)
    return user


def end_tokens(session: Session, user: User, *, keep_personal: bool) -> None:
    """Revoke every valid token of ``user`` (only the session tokens when ``keep_personal``)."""
    now = utcnow()
    which = [ApiToken.user_id == user.id, ApiToken.revoked_at.is_(None)]
    if keep_personal:
        which.append(ApiToken.kind == TokenKind.session.value)
    session.execute(
        sa.update(ApiToken).where(*which).values(revoked_at=now), execution_options={"synchronize_session": False}
    )
    TOKENS.drop(user_id=user.id)
    revocation.bump_after_commit(session)


# ----------------------------------------------------------------------------- sharing
#
# A share names its grantee by e-mail. When an account has that e-mail the share grants
# access at once; otherwise it is kept as an invitation (``Share.email``, no ``user_id``)
# that the account created later with that e-mail receives (:func:`create_user`). Both
# answer alike (201, the same fields, the same work), and are listed alike, so sharing does
# not tell a member whether an address has an account.


def _object_of(share: Share) -> tuple[str, int]:
    for object_type, model in OBJECT_TYPES.items():
        object_id = getattr(share, SHARE_COLUMN[model].key)
        if object_id is not None:
            return object_type, object_id
    raise AssertionError("share without object")


def _share_out(share: Share, email: str) -> ShareOut:
    object_type, object_id = _object_of(share)
    return ShareOut(
        id=share.id,
        object_type=object_type,
        object_id=object_id,
        email=email,
        permission=share.permission,
        created_at=share.created_at,
    )


def share(session: Session, owner: User, body: ShareCreate) -> ShareOut:
    model = OBJECT_TYPES[body.object_type]
    obj = get_for(session, model, body.object_id, owner, need="owner")
    email = body.email.strip().lower()
    if email == owner.email:
        raise InvalidInput.one("email", f"you own this {LABEL[model]}")
    column = SHARE_COLUMN[model]
    grantee = repo.user_by_email(session, email)
    who = Share.user_id == grantee.id if grantee is not None else Share.email == email
    existing = session.scalar(sa.select(Share).where(who, column == obj.id))
    if existing is None:
        existing = Share(
            user_id=grantee.id if grantee is not None else None,
            email=None if grantee is not None else email,
            permission=body.permission,
            created_by_id=owner.id,
            **{column.key: obj.id},
        )
        session.add(existing)
    else:
        existing.permission = body.permission
    session.flush()
    return _share_out(existing, email)


def accept_invitations(session: Session, user: User) -> int:
    """Give ``user`` the shares that were invitations to their e-mail; returns how many."""
    result = session.execute(
        sa.update(Share).where(Share.email == user.email, Share.user_id.is_(None)).values(user_id=user.id, email=None)
    )
    assert isinstance(result, sa.CursorResult)  # an UPDATE's result is a CursorResult (Session.execute is typed Result)
    return result.rowcount or 0


def list_shares(session: Session, user: User, object_type: str, object_id: int) -> list[ShareOut]:
    model = OBJECT_TYPES[object_type]
    get_for(session, model, object_id, user, need="owner")
    return [_share_out(s, email) for s, email in repo.shares_of(session, SHARE_COLUMN[model], object_id)]


def delete_share(session: Session, user: User, share_id: int) -> None:
    """The object's owner removes a share (or an invitation), or the grantee gives it up."""
    row = session.get(Share, share_id)
    if row is None:
        raise NotFound("share", share_id)
    if row.user_id != user.id:
        object_type, object_id = _object_of(row)
        try:
            get_for(session, OBJECT_TYPES[object_type], object_id, user, need="owner")
        except (PermissionDenied, NotFound):
            raise NotFound("share", share_id) from None
    session.delete(row)
    session.flush()
