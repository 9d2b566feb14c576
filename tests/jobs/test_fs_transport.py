"""The embedded broker writes a message atomically: a worker polling the folder while the
message is being written sees no message, never an empty or partial one."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from kombu import Connection
from kombu.exceptions import ChannelError


def _channel(tmp_path: Path) -> Any:
    from alcove.jobs.fs_transport import TRANSPORT

    folder = tmp_path / "messages"
    folder.mkdir()
    conn = Connection(
        "filesystem://",
        transport=TRANSPORT,
        transport_options={"data_folder_in": str(folder), "data_folder_out": str(folder)},
    )
    return conn, conn.default_channel, folder


def test_a_message_being_written_is_invisible_to_readers(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from queue import Empty

    from alcove.jobs import fs_transport

    conn, ch, folder = _channel(tmp_path)
    seen_during_write: list[Any] = []
    real_replace = fs_transport.os.replace

    def replace(src: str, dst: str) -> None:
        assert Path(src).read_bytes()  # the whole payload is in the part file
        try:
            seen_during_write.append(ch._get("default"))
        except Empty:
            seen_during_write.append(None)
        real_replace(src, dst)

    monkeypatch.setattr(fs_transport.os, "replace", replace)
    ch._put("default", {"body": "step 1"})
    assert seen_during_write == [None]
    assert ch._get("default") == {"body": "step 1"}
    assert list(folder.iterdir()) == []  # no part file left behind
    conn.release()


def test_failed_write_leaves_no_part_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from alcove.jobs import fs_transport

    conn, ch, folder = _channel(tmp_path)

    def fail(src: str, dst: str) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(fs_transport.os, "replace", fail)
    with pytest.raises(ChannelError):
        ch._put("default", {"body": "x"})
    assert list(folder.iterdir()) == []
    conn.release()


def test_embedded_celery_config_uses_the_atomic_transport(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from alcove.jobs import celery_config
    from alcove.settings import Settings

    cfg = celery_config(Settings(data_dir=tmp_path, broker_url=""))
    assert cfg["broker_transport"] == "alcove.jobs.fs_transport:Transport"
    assert celery_config(Settings(data_dir=tmp_path, broker_url="redis://127.0.0.1:6379/0"))["broker_transport"] is None
