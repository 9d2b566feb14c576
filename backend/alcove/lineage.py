"""Where a campaign's iteration lives: a fork reuses its source's iterations up to the fork
point (its pool version, model version, OCP solution), recursively through forks of forks.
Shared by every domain that stores per-iteration rows (pool, surrogates, solving)."""

from __future__ import annotations

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.errors import NotFound
from alcove.models import Campaign


def resolve_iteration(s: Session, campaign_id: int, index: int) -> tuple[int, int]:
    """(campaign id, index) holding iteration ``index`` of campaign ``campaign_id``: the
    campaign itself, or for an index up to a fork's ``source_iteration`` its source's."""
    cid = campaign_id
    while True:
        row = s.execute(
            sa.select(Campaign.source_campaign_id, Campaign.source_iteration).where(Campaign.id == cid)
        ).first()
        if row is None:
            raise NotFound("campaign", cid)
        source, through = row
        if source is None or through is None or index > through:
            return cid, index
        cid = source
