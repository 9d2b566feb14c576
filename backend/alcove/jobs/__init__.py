"""Celery configuration shared by the API (which only *sends* jobs, by name) and the
workers (which register and run them). Importing this package never imports torch,
casadi or the science code.

Queues: ``ocp``, ``oracle``, ``train`` for the heavy steps, ``artifacts`` for the model
artifact zips a download needs (a child process with torch each) and ``default`` for
orchestration (evaluate, append, reconcile, smoke). Routing is by job name: a job named
``alcove.<queue>.<what>`` goes to ``<queue>`` (e.g. ``alcove.train.step``); any other name
goes to ``default``. ``send_job(..., queue=...)`` overrides the route.

Settings for long scientific jobs: ``task_acks_late``, ``worker_prefetch_multiplier=1``,
JSON only, results ignored (the database is the record), Redis ``visibility_timeout`` =
``ALCOVE_BROKER_VISIBILITY_TIMEOUT`` (must exceed the longest job, or Redis redelivers it to
another worker while it still runs). Workers never rely on Celery to avoid a duplicate
delivery: every job claims its row with a conditional update first.

The embedded default uses kombu's filesystem transport (folders under
``ALCOVE_DATA_DIR/broker``, no server; :mod:`alcove.jobs.fs_transport` makes writing a
message atomic, so a worker polling every few ms never reads a half-written file). Note
its limits: a message is taken out of the folder when a worker fetches it, so a worker killed with SIGKILL loses it; the
campaign reconciler (lease expiry in the database) is what re-enqueues such steps.
"""

from __future__ import annotations

import threading
import uuid
from typing import TYPE_CHECKING, Any

from kombu import Exchange, Queue

from alcove.settings import Settings, get_settings

if TYPE_CHECKING:
    from celery import Celery

QUEUES: tuple[str, ...] = ("default", "ocp", "oracle", "train", "artifacts")
DEFAULT_QUEUE = "default"

#: Job names defined by this package.
SMOKE_JOB = "alcove.default.smoke"


def queue_for(job_name: str) -> str:
    """The queue a job name routes to (``alcove.<queue>.<what>``, else ``default``)."""
    parts = job_name.split(".")
    if len(parts) >= 3 and parts[0] == "alcove" and parts[1] in QUEUES:
        return parts[1]
    return DEFAULT_QUEUE


def _route(name: str, args: Any, kwargs: Any, options: Any, task: Any = None, **kw: Any) -> dict[str, str]:
    return {"queue": queue_for(name)}


def broker_folders(settings: Settings) -> dict[str, str]:
    base = settings.broker_dir
    folders = {
        "data_folder_in": base / "messages",
        "data_folder_out": base / "messages",
        "processed_folder": base / "processed",
        "control_folder": base / "control",
    }
    for p in folders.values():
        p.mkdir(parents=True, exist_ok=True)
    return {k: str(v) for k, v in folders.items()}


def celery_config(settings: Settings | None = None) -> dict[str, Any]:
    """The Celery configuration for ``settings`` (the same in API and worker)."""
    s = settings or get_settings()
    transport_options: dict[str, Any]
    if s.is_embedded_broker:
        transport_options = {
            **broker_folders(s),
            "store_processed": False,
            "polling_interval": s.broker_polling_interval,
        }
    else:
        transport_options = {"visibility_timeout": s.broker_visibility_timeout}
        if s.broker_key_prefix:
            transport_options["global_keyprefix"] = s.broker_key_prefix
    exchange = Exchange("alcove", type="direct")
    return {
        "broker_url": s.broker_url,
        # the embedded broker: kombu's filesystem transport with atomic message files (see fs_transport)
        "broker_transport": "alcove.jobs.fs_transport:Transport" if s.is_embedded_broker else None,
        "broker_transport_options": transport_options,
        "broker_connection_retry_on_startup": True,
        "result_backend": None,
        "task_ignore_result": True,
        "task_store_errors_even_if_ignored": False,
        "task_serializer": "json",
        "result_serializer": "json",
        "accept_content": ["json"],
        "event_serializer": "json",
        "task_acks_late": True,
        "task_reject_on_worker_lost": False,  # a killed job is re-enqueued by the reconciler, not by Celery
        "worker_prefetch_multiplier": 1,
        "worker_cancel_long_running_tasks_on_connection_loss": False,
        "task_queues": tuple(Queue(q, exchange, routing_key=q) for q in QUEUES),
        "task_default_queue": DEFAULT_QUEUE,
        "task_default_exchange": "alcove",
        "task_default_routing_key": DEFAULT_QUEUE,
        "task_routes": (_route,),
        "task_create_missing_queues": False,
        "worker_send_task_events": False,
        "task_send_sent_event": False,
        "worker_enable_remote_control": not s.is_embedded_broker,
        "worker_hijack_root_logger": False,
        "timezone": "UTC",
        "enable_utc": True,
    }


def create_celery_app(settings: Settings | None = None, *, include: list[str] | None = None) -> Celery:
    from celery import Celery

    app = Celery("alcove", include=include or [])
    app.conf.update(celery_config(settings))
    return app


#: kombu's retry policy of a quick send: reconnect once or twice, then raise
QUICK_RETRY = {"max_retries": 2, "interval_start": 0.0, "interval_step": 0.2, "interval_max": 0.3}

_sender_lock = threading.Lock()
_sender: Celery | None = None


def get_sender() -> Celery:
    """A process-wide Celery app used only to send jobs (API, CLI)."""
    global _sender
    with _sender_lock:
        if _sender is None:
            _sender = create_celery_app()
        return _sender


def reset_sender() -> None:
    global _sender
    with _sender_lock:
        _sender = None


def send_job(
    name: str,
    *args: Any,
    queue: str | None = None,
    task_id: str | None = None,
    app: Celery | None = None,
    quick: bool = False,
    **kwargs: Any,
) -> str:
    """Send job ``name`` by name (no import of its code) and return the message id.

    Call it only after the transaction that made the job necessary has committed (the
    application sends through :mod:`alcove.jobs.outbox`). ``quick``: give up after a short
    reconnect (about half a second) instead of kombu's default retries, so that a caller
    holding a request or a transaction is not kept waiting by a broker that is down.
    """
    q = queue or queue_for(name)
    if q not in QUEUES:
        raise ValueError(f"unknown queue {q!r}; expected one of {QUEUES}")
    tid = task_id or str(uuid.uuid4())
    options: dict[str, Any] = {"retry_policy": QUICK_RETRY} if quick else {}
    (app or get_sender()).send_task(
        name, args=list(args), kwargs=kwargs, queue=q, routing_key=q, task_id=tid, **options
    )
    return tid
