"""The Celery settings the architecture requires, for both brokers."""

from __future__ import annotations

from pathlib import Path

import pytest

from alcove.jobs import QUEUES, celery_config, create_celery_app, queue_for
from alcove.settings import Settings


def test_long_job_settings_on_redis() -> None:
    cfg = celery_config(
        Settings(broker_url="redis://127.0.0.1:6379/0", broker_visibility_timeout=43200, broker_key_prefix="p:")
    )
    assert cfg["task_acks_late"] is True
    assert cfg["worker_prefetch_multiplier"] == 1
    assert cfg["task_serializer"] == "json" and cfg["accept_content"] == ["json"]
    assert cfg["task_ignore_result"] is True and cfg["result_backend"] is None
    assert cfg["broker_transport_options"] == {"visibility_timeout": 43200, "global_keyprefix": "p:"}
    assert {q.name for q in cfg["task_queues"]} == set(QUEUES) == {"default", "ocp", "oracle", "train", "artifacts"}


def test_visibility_timeout_exceeds_the_job_lease_and_an_hour() -> None:
    s = Settings()
    assert s.broker_visibility_timeout > 3600 and s.broker_visibility_timeout > s.job_lease_seconds


def test_embedded_broker_uses_folders_in_data_dir(tmp_path: Path) -> None:
    cfg = celery_config(Settings(data_dir=tmp_path))
    opts = cfg["broker_transport_options"]
    assert cfg["broker_url"].startswith("filesystem://")
    for key in ("data_folder_in", "data_folder_out", "processed_folder", "control_folder"):
        assert Path(opts[key]).is_dir() and Path(opts[key]).is_relative_to(tmp_path)


def test_routes_by_job_name() -> None:
    assert queue_for("alcove.ocp.solve") == "ocp"
    assert queue_for("alcove.oracle.replay") == "oracle"
    assert queue_for("alcove.train.fit") == "train"
    assert queue_for("alcove.default.smoke") == "default"
    assert queue_for("alcove.reconcile") == "default"
    app = create_celery_app(Settings(broker_url="memory://"))
    assert app.amqp.router.route({}, "alcove.train.fit")["queue"].name == "train"


def test_a_worker_counts_as_dead_only_after_several_missed_heartbeats() -> None:
    """A dead-worker threshold shorter than two heartbeats would take steps from live workers:
    refused at start, naming both settings."""
    from pydantic import ValidationError

    assert Settings(worker_heartbeat_seconds=2, worker_dead_seconds=10).worker_dead_seconds == 10
    with pytest.raises(ValidationError) as err:
        Settings(worker_heartbeat_seconds=30, worker_dead_seconds=10)
    assert "ALCOVE_WORKER_DEAD_SECONDS (10) must be at least twice ALCOVE_WORKER_HEARTBEAT_SECONDS (30)" in str(
        err.value
    )
