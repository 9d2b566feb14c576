"""API tests run the real app (TestClient) on the session's migrated PostgreSQL schema.

Fixtures give three users: ``owner`` and ``other`` (members) and ``admin``, each with a
bearer token; ``as_(user)`` gives headers. Data is committed (the API opens its own
sessions), so tests use unique names.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from .helpers import Account, make_account


@pytest.fixture(scope="session")
def api_settings(pg_url: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    mp = pytest.MonkeyPatch()
    mp.setenv("ALCOVE_DATABASE_URL", pg_url)
    mp.setenv("ALCOVE_DATA_DIR", str(tmp_path_factory.mktemp("alcove-api")))
    mp.delenv("ALCOVE_BROKER_URL", raising=False)
    mp.delenv("ALCOVE_COMMAND_ORACLES_FILE", raising=False)
    from alcove.settings import get_settings

    get_settings.cache_clear()
    yield
    mp.undo()
    get_settings.cache_clear()


@pytest.fixture(scope="session")
def app(api_settings: None, tmp_path_factory: pytest.TempPathFactory):
    from alcove.app import create_app
    from alcove.settings import get_settings

    settings = get_settings().model_copy(update={"static_dir": tmp_path_factory.mktemp("no-frontend")})
    return create_app(settings)


@pytest.fixture(scope="session")
def client(app) -> TestClient:
    return TestClient(app)


def _without_a_running_campaigns_limit(account: Account) -> Account:
    """The session's members start campaigns in many tests, and no worker runs them (they stay
    queued): the running-campaigns limit would make later tests' campaigns wait depending on the
    order the tests run in. The limits' own tests use fresh accounts."""
    from alcove.db import open_transaction
    from alcove.models import User
    from alcove.users.limits import set_own
    from alcove.users.schemas import JobLimitsUpdate

    with open_transaction() as s:
        user = s.get(User, account.id)
        assert user is not None
        set_own(s, user, JobLimitsUpdate(max_running_campaigns=None))
    return account


@pytest.fixture(scope="session")
def owner(api_settings: None) -> Account:
    return _without_a_running_campaigns_limit(make_account("member", "owner"))


@pytest.fixture(scope="session")
def other(api_settings: None) -> Account:
    return _without_a_running_campaigns_limit(make_account("member", "other"))


@pytest.fixture(scope="session")
def admin(api_settings: None) -> Account:
    return make_account("admin", "admin")
