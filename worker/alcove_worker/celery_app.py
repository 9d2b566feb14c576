"""The worker's Celery app: alcove's shared configuration plus the job modules and the
worker lifecycle hooks (database heartbeat, the job outbox's relay and delivery marks, fresh
connections in forked children).

Start a worker with ``alcove worker --queues ocp,oracle,train,default``; the raw Celery
equivalent is ``celery -A alcove_worker.celery_app worker -Q ... -n NAME@%h``.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from celery import signals

from alcove.jobs import create_celery_app
from alcove.settings import get_settings

if TYPE_CHECKING:
    from alcove.jobs.heartbeat import HeartbeatThread
    from alcove.jobs.outbox import RelayThread

log = logging.getLogger(__name__)

#: Modules whose import registers jobs. Add new job modules here.
JOB_MODULES = ["alcove_worker.jobs"]

app = create_celery_app(include=JOB_MODULES)

_heartbeat: HeartbeatThread | None = None
_relay: RelayThread | None = None


@signals.worker_process_init.connect
def _fresh_connections_in_child(**_: Any) -> None:
    """A forked pool process must not reuse the parent's pooled DB connections."""
    from alcove.db import dispose_engines

    dispose_engines(close=False)


@signals.task_prerun.connect
def _mark_delivered(task_id: str | None = None, **_: Any) -> None:
    """The job reached a worker: its outbox row is not sent again after a broker restart."""
    from alcove.jobs.outbox import mark_delivered

    if task_id:
        try:
            mark_delivered(task_id)
        except Exception:  # the job itself still runs (and claims its row first)
            log.exception("could not mark job %s delivered", task_id)


@signals.worker_ready.connect
def _start_heartbeat(sender: Any = None, **_: Any) -> None:
    global _heartbeat, _relay
    from alcove.jobs.heartbeat import HeartbeatThread
    from alcove.jobs.outbox import RelayThread

    consumer = sender
    name = consumer.hostname
    queues = sorted(q.name for q in consumer.task_consumer.queues) if consumer.task_consumer else []
    concurrency = getattr(consumer.controller, "concurrency", None) if getattr(consumer, "controller", None) else None
    _heartbeat = HeartbeatThread(name, get_settings().worker_heartbeat_seconds, queues, concurrency)
    _heartbeat.start()
    _relay = RelayThread(get_settings().outbox_relay_seconds)  # jobs waiting for the broker (see jobs/outbox.py)
    _relay.start()
    log.info("alcove worker %s ready on queues %s", name, ",".join(queues))


@signals.worker_shutdown.connect
def _stop_heartbeat(**_: Any) -> None:
    if _relay is not None:
        _relay.stop()
    if _heartbeat is not None:
        _heartbeat.stop()
