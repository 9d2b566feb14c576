"""Live updates: the campaign events as server-sent events, the one live channel of the UI.

Each API process runs one :class:`EventHub` while anyone listens: a single query per poll
reads the events committed since the last one (for every campaign at once) and hands each
event, serialised once, to every open stream of that process. A campaign page listens to
its campaign (``/campaigns/{id}/events/stream``), the campaign list to every campaign the
user may see (``/campaigns/events/stream``); the browser refetches only the data an event
says has changed. 50 viewers of one campaign cost one query per poll, not 50.

Event ids come from the database and a transaction that took a smaller id can commit after
one that took a larger id (PostgreSQL with several workers). The hub remembers such holes
below its cursor for :data:`GAP_RETENTION_S` and reads them again, so a late commit is
still delivered; a rolled-back insert leaves a hole that simply expires.
"""

from __future__ import annotations

import asyncio
import json
import logging
import re
import time
import weakref
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, field
from functools import partial
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request
from fastapi.responses import StreamingResponse

from alcove.api.params import MAX_ID, ObjectId
from alcove.campaigns import repository as repo
from alcove.campaigns.views import live_access
from alcove.campaigns.views.schemas import EventRead
from alcove.db import get_sessionmaker
from alcove.models import Campaign, CampaignStatus
from alcove.users.access import get_for
from alcove.users.auth import CurrentToken, CurrentUser

log = logging.getLogger(__name__)

#: Seconds between two reads of new events (while at least one stream is open).
POLL_S = 1.0
#: Seconds between keep-alive comments on an idle stream (proxies close silent connections).
KEEPALIVE_S = 15.0
#: How long an id below the cursor that was not seen yet is looked for again.
GAP_RETENTION_S = 60.0
#: Holes wider than this (a sequence jump, a bulk rollback) are not watched.
MAX_GAP = 200
TERMINAL = {CampaignStatus.completed.value, CampaignStatus.failed.value, CampaignStatus.cancelled.value}


@dataclass(frozen=True)
class Frame:
    """One event ready to send: its ids and its SSE text."""

    id: int
    campaign_id: int
    kind: str
    terminal: bool
    text: str

    @classmethod
    def of(cls, e: EventRead) -> Frame:
        terminal = e.kind == "status" and (e.data or {}).get("to") in TERMINAL
        text = f"id: {e.id}\nevent: {e.kind}\ndata: {e.model_dump_json()}\n\n"
        return cls(e.id, e.campaign_id, e.kind, terminal, text)


@dataclass(eq=False)
class Subscription:
    campaign_id: int | None  # None: every campaign
    queue: asyncio.Queue[list[Frame]] = field(default_factory=asyncio.Queue)


class EventHub:
    """Reads new events once per poll for all open streams of this process."""

    def __init__(self, poll_s: float = POLL_S) -> None:
        self.poll_s = poll_s
        self._subs: set[Subscription] = set()
        self._task: asyncio.Task[None] | None = None
        self._cursor: int | None = None
        self._gaps: dict[int, float] = {}  # missing id -> monotonic time it was first missed
        self._lock = asyncio.Lock()
        self.polls = 0  # for tests and the bench
        self.subscriptions = 0  # every subscription so far (for tests)

    async def subscribe(self, campaign_id: int | None) -> Subscription:
        """A new subscription. Every event committed after this returns is delivered (the
        caller reads what came before from the database)."""
        async with self._lock:
            if self._cursor is None:
                self._cursor = await asyncio.to_thread(self._last_id)
            sub = Subscription(campaign_id)
            self._subs.add(sub)
            self.subscriptions += 1
            if self._task is None or self._task.done():
                self._task = asyncio.get_running_loop().create_task(self._run(), name="alcove-event-hub")
            return sub

    def unsubscribe(self, sub: Subscription) -> None:
        self._subs.discard(sub)

    async def _run(self) -> None:
        while self._subs:
            try:
                frames = await asyncio.to_thread(self._read_new)
            except Exception:  # the database may be briefly unavailable: try again next poll
                log.exception("reading new campaign events failed")
                frames = []
            if frames:
                for sub in list(self._subs):
                    mine = (
                        frames if sub.campaign_id is None else [f for f in frames if f.campaign_id == sub.campaign_id]
                    )
                    if mine:
                        sub.queue.put_nowait(mine)
            await asyncio.sleep(self.poll_s)
        # the last stream closed: forget the cursor, the next subscriber starts from "now"
        self._cursor = None
        self._gaps.clear()

    @staticmethod
    def _last_id() -> int:
        with get_sessionmaker()() as s:
            return repo.last_event_id(s)

    def _read_new(self) -> list[Frame]:
        assert self._cursor is not None
        now = time.monotonic()
        self._gaps = {i: t for i, t in self._gaps.items() if now - t < GAP_RETENTION_S}
        with get_sessionmaker()() as s:
            rows = repo.events_since(s, self._cursor, sorted(self._gaps))
            self.polls += 1
            frames = [Frame.of(EventRead.model_validate(e)) for e in rows]
        for f in frames:
            self._gaps.pop(f.id, None)
            if f.id > self._cursor:
                if f.id - self._cursor <= MAX_GAP:  # a jump of the id sequence is not a hole to watch
                    self._gaps.update((i, now) for i in range(self._cursor + 1, f.id))
                self._cursor = f.id
        return frames

    @property
    def cursor(self) -> int | None:
        """The id of the last event read (None while nobody listens)."""
        return self._cursor

    @property
    def listeners(self) -> int:
        """Open subscriptions (streams) of this process."""
        return len(self._subs)


_HUBS: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, EventHub] = weakref.WeakKeyDictionary()


def subscriptions() -> int:
    """Streams subscribed so far in this process, over its event loops' hubs."""
    return sum(hub.subscriptions for hub in list(_HUBS.values()))


def current_hub() -> EventHub:
    """The hub of this process's event loop (one per API process)."""
    loop = asyncio.get_running_loop()
    hub = _HUBS.get(loop)
    if hub is None:
        hub = _HUBS[loop] = EventHub()
    return hub


router = APIRouter(prefix="/campaigns", tags=["campaigns"])

SSE_RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {"content": {"text/event-stream": {"schema": {"type": "string"}}}, "description": "Server-Sent Events"}
}
After = Annotated[
    int | None,
    Query(ge=0, le=MAX_ID, description="resume after this event id (the last id you received); omit to start now"),
]
Timeout = Annotated[float, Query(ge=0, le=3600, description="close the stream after this many seconds")]
#: At most this many missed events are sent on a resume; more: ``ready`` says ``complete: false``.
BACKLOG_LIMIT = 1000


#: A ``Last-Event-ID`` this stream sent: ASCII digits only (``str.isdigit`` also accepts "²").
_EVENT_ID = re.compile(r"[0-9]{1,19}")


def _resume_from(request: Request, after: int | None) -> int | None:
    """``after``, or the ``Last-Event-ID`` header if it is later; a header that is not an event
    id (not ASCII digits, or above the largest id) is ignored, as a browser's first connection."""
    last = request.headers.get("last-event-id")
    if last and _EVENT_ID.fullmatch(last) and int(last) <= MAX_ID:
        return max(after or 0, int(last))
    return after


def _ready(cursor: int, complete: bool) -> str:
    """The frame after the backlog: from here on every event is sent as it is committed.
    ``complete: false`` (first connection, or more missed events than the backlog holds)
    tells the client to reload what it shows."""
    return f"id: {cursor}\nevent: ready\ndata: {json.dumps({'last_event_id': cursor, 'complete': complete})}\n\n"


async def _stream(
    hub: EventHub,
    sub: Subscription,
    first: list[str],
    timeout: float,
    accept: Callable[[Frame], Awaitable[tuple[bool, bool]]],
    sent: set[int],
    recheck: Callable[[], Awaitable[str | None]],
) -> AsyncIterator[str]:
    """Send ``first`` (backlog and ``ready``), then what the hub delivers except the ids
    already ``sent`` (backlog and hub overlap around the moment of subscribing); ``accept``
    says whether a frame goes out and whether the stream ends after it. Every
    ``live_access.RECHECK_S`` seconds, and before sending once that much time has passed,
    ``recheck`` says whether the stream may go on (None) or why it ends (then an ``end`` frame
    with the reason is the last one)."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout
    written = next_check = loop.time()
    try:
        yield "".join(first)
        while (left := deadline - loop.time()) > 0:
            now = loop.time()
            wait = min(KEEPALIVE_S - (now - written), left, max(next_check - now, 0.05))
            try:
                frames = await asyncio.wait_for(sub.queue.get(), timeout=max(wait, 0.0))
            except TimeoutError:
                frames = []
            if loop.time() >= next_check:
                gone = await recheck()
                if gone is not None:
                    yield live_access.ended(gone)
                    return
                next_check = loop.time() + live_access.RECHECK_S
            # what one poll delivered goes out as one write (one wake-up of the viewer), not one per event
            out: list[str] = []
            last = False
            for f in frames:
                if f.id in sent:
                    continue
                send, last = await accept(f)
                if send:
                    out.append(f.text)
                if last:
                    break
            if not out and loop.time() - written >= KEEPALIVE_S:
                out.append(": keep-alive\n\n")
            if out:
                yield "".join(out)
                written = loop.time()
            if last:
                return
    finally:
        hub.unsubscribe(sub)


async def _visible_only(visible: live_access.Visible, f: Frame) -> tuple[bool, bool]:
    return await visible(f.campaign_id), False


async def _ends_when_terminal(f: Frame) -> tuple[bool, bool]:
    return True, f.terminal


@router.get(
    "/events/stream",
    operation_id="stream_all_campaign_events",
    response_class=StreamingResponse,
    responses=SSE_RESPONSES,
)
async def stream_all_campaign_events(
    user: CurrentUser, token: CurrentToken, request: Request, after: After = None, timeout: Timeout = 300
) -> StreamingResponse:
    """Events of every campaign you may see, as Server-Sent Events (``id`` = event id,
    ``event`` = kind, ``data`` = the event with its ``campaign_id``): the campaign list's
    live channel. Resuming with ``after`` (or ``Last-Event-ID``) first sends the events you
    missed; then a ``ready`` event; then every new event as it is committed. The stream ends
    after ``timeout`` seconds: reconnect with the last id. Every few seconds the stream re-checks
    your token and which campaigns you may see: it stops sending a campaign's events once you
    may no longer see it, and ends (an ``end`` event says why) once the token is revoked or
    expired."""
    resume = _resume_from(request, after)
    hub = current_hub()
    sub = await hub.subscribe(None)
    visible = live_access.Visible(user, token.id)
    cursor = hub.cursor or 0

    def backlog() -> list[Frame]:
        if resume is None:
            return []
        with get_sessionmaker()() as s:
            rows = repo.visible_events(s, user, resume, cursor, BACKLOG_LIMIT + 1)
        visible.visible |= {e.campaign_id for e in rows}
        return [Frame.of(EventRead.model_validate(e)) for e in rows]

    try:
        frames = await asyncio.to_thread(backlog)
    except BaseException:
        hub.unsubscribe(sub)
        raise
    complete = resume is not None and len(frames) <= BACKLOG_LIMIT
    frames = frames[:BACKLOG_LIMIT]
    first = [f.text for f in frames] + [_ready(cursor, complete)]
    sent = {f.id for f in frames}
    return _sse(_stream(hub, sub, first, timeout, partial(_visible_only, visible), sent, visible.recheck))


@router.get(
    "/{campaign_id:integer}/events/stream",
    operation_id="stream_campaign_events",
    response_class=StreamingResponse,
    responses=SSE_RESPONSES,
)
async def stream_campaign_events(
    campaign_id: ObjectId,
    user: CurrentUser,
    token: CurrentToken,
    request: Request,
    after: After = None,
    timeout: Timeout = 300,
) -> StreamingResponse:
    """The campaign's events as Server-Sent Events (``id`` = event id, ``event`` = kind,
    ``data`` = the event): the campaign page's live channel. Resuming with ``after`` (or
    ``Last-Event-ID``) first sends the events you missed; then a ``ready`` event; then every
    new event as it is committed. The stream ends after the event that makes the campaign
    terminal (at once if it already is) or after ``timeout`` seconds: reconnect with the last id.
    Every few seconds the stream re-checks your token and your access to the campaign, and ends
    (an ``end`` event says why) once either is gone (a revoked token, a removed share)."""
    resume = _resume_from(request, after)
    hub = current_hub()
    sub = await hub.subscribe(campaign_id)
    cursor = hub.cursor or 0

    def backlog() -> tuple[list[Frame], bool]:
        with get_sessionmaker()() as s:
            c = get_for(s, Campaign, campaign_id, user)
            rows = [] if resume is None else repo.events(s, campaign_id, resume, BACKLOG_LIMIT + 1, through=cursor)
            return [Frame.of(EventRead.model_validate(e)) for e in rows], c.status in TERMINAL

    try:
        frames, terminal = await asyncio.to_thread(backlog)
    except BaseException:
        hub.unsubscribe(sub)
        raise
    complete = resume is not None and len(frames) <= BACKLOG_LIMIT
    frames = frames[:BACKLOG_LIMIT]
    first = [f.text for f in frames] + [_ready(cursor, complete)]
    if terminal:
        hub.unsubscribe(sub)

        async def once() -> AsyncIterator[str]:
            for text in first:
                yield text

        return _sse(once())
    access = live_access.CampaignAccess(token.id, campaign_id)
    return _sse(_stream(hub, sub, first, timeout, _ends_when_terminal, {f.id for f in frames}, access))


def _sse(frames: AsyncIterator[str]) -> StreamingResponse:
    return StreamingResponse(
        frames, media_type="text/event-stream", headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"}
    )
