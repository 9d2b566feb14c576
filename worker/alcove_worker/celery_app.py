"""The worker's Celery app: alcove's shared configuration plus the job modules and the
worker lifecycle hooks (database heartbeat, fresh connections in forked children).

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

log = logging.getLogger(__name__)

#: Modules whose import registers jobs. Add new job modules here.
JOB_MODULES = ["alcove_worker.jobs"]

app = create_celery_app(include=JOB_MODULES)

_heartbeat: HeartbeatThread | None = None


@signals.worker_process_init.connect
def _fresh_connections_in_child(**_: Any) -> None:
    """A forked pool process must not reuse the parent's pooled DB connections."""
    from alcove.db import dispose_engines

    dispose_engines(close=False)


@signals.worker_ready.connect
def _start_heartbeat(sender: Any = None, **_: Any) -> None:
    global _heartbeat
    from alcove.jobs.heartbeat import HeartbeatThread

    consumer = sender
    name = consumer.hostname
    queues = sorted(q.name for q in consumer.task_consumer.queues) if consumer.task_consumer else []
    concurrency = getattr(consumer.controller, "concurrency", None) if getattr(consumer, "controller", None) else None
    _heartbeat = HeartbeatThread(name, get_settings().worker_heartbeat_seconds, queues, concurrency)
    _heartbeat.start()
    log.info("alcove worker %s ready on queues %s", name, ",".join(queues))


@signals.worker_shutdown.connect
def _stop_heartbeat(**_: Any) -> None:
    if _heartbeat is not None:
        _heartbeat.stop()
