"""Request dependencies shared by the routers."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Annotated

from fastapi import Depends
from sqlalchemy.orm import Session

from alcove.db import get_sessionmaker
from alcove.settings import Settings, get_settings


def settings_dep() -> Settings:
    return get_settings()


def get_session() -> Iterator[Session]:
    """One session per request. The route (or the service it calls) decides when to commit;
    anything not committed is rolled back at the end of the request."""
    factory = get_sessionmaker()
    with factory() as session:
        yield session


SessionDep = Annotated[Session, Depends(get_session)]
SettingsDep = Annotated[Settings, Depends(settings_dep)]
