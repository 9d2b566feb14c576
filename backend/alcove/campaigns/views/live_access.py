"""What an open event stream re-checks every :data:`RECHECK_S` seconds: that the token it was
opened with is still valid (not revoked, not expired, its user active) and what that user may
see. A campaign's stream ends when either is gone; the list stream ends when the token is gone
and stops sending the events of a campaign that is no longer visible (a removed share)."""

from __future__ import annotations

import asyncio
import json
import time

from alcove.campaigns import repository as repo
from alcove.db import get_sessionmaker
from alcove.errors import NotFound, PermissionDenied
from alcove.models import Campaign, User
from alcove.users import service as users
from alcove.users.access import get_for

#: Seconds between two re-checks of an open stream's token and access.
RECHECK_S = 3.0
#: How long a stream of all campaigns trusts "not visible to this user" (a share may change it).
HIDDEN_RECHECK_S = 30.0

TOKEN_GONE = "token revoked or expired, or account deactivated"
ACCESS_GONE = "you may no longer see this campaign"


def ended(reason: str) -> str:
    """The stream's last frame: why the server closes it (reconnecting needs a valid token)."""
    return f"event: end\ndata: {json.dumps({'reason': reason})}\n\n"


class CampaignAccess:
    """Re-checks the token and the access to one campaign."""

    def __init__(self, token_id: int, campaign_id: int) -> None:
        self.token_id = token_id
        self.campaign_id = campaign_id

    async def __call__(self) -> str | None:
        """None while the stream may go on, else why it ends."""
        return await asyncio.to_thread(self._check)

    def _check(self) -> str | None:
        with get_sessionmaker()() as s:
            user = users.user_of_token(s, self.token_id)
            if user is None:
                return TOKEN_GONE
            try:
                get_for(s, Campaign, self.campaign_id, user)
            except (NotFound, PermissionDenied):
                return ACCESS_GONE
        return None


class Visible:
    """Which campaigns a user may see: known ones at once, unknown ones checked in a thread
    (a "not visible" answer is trusted for :data:`HIDDEN_RECHECK_S`: a share may change it).
    Calling :meth:`recheck` re-reads the token and the known campaigns from the database."""

    def __init__(self, user: User, token_id: int) -> None:
        self.user = user
        self.token_id = token_id
        self.visible: set[int] = set()
        self.hidden: dict[int, float] = {}

    async def __call__(self, campaign_id: int) -> bool:
        if campaign_id in self.visible:
            return True
        checked = self.hidden.get(campaign_id)
        if checked is not None and time.monotonic() - checked < HIDDEN_RECHECK_S:
            return False
        if await asyncio.to_thread(self._may_see, campaign_id):
            self.visible.add(campaign_id)
            self.hidden.pop(campaign_id, None)
            return True
        self.hidden[campaign_id] = time.monotonic()
        return False

    def _may_see(self, campaign_id: int) -> bool:
        with get_sessionmaker()() as s:
            return bool(repo.visible_campaign_ids(s, self.user, [campaign_id]))

    async def recheck(self) -> str | None:
        """None while the stream may go on (the campaigns no longer visible are forgotten),
        else why it ends."""
        return await asyncio.to_thread(self._recheck)

    def _recheck(self) -> str | None:
        with get_sessionmaker()() as s:
            user = users.user_of_token(s, self.token_id)
            if user is None:
                return TOKEN_GONE
            still = repo.visible_campaign_ids(s, user, sorted(self.visible)) if self.visible else set()
            s.expunge(user)
        now = time.monotonic()
        self.hidden.update((cid, now) for cid in self.visible - still)
        self.visible, self.user = still, user
        return None
