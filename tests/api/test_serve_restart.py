"""`alcove serve` restarts at once after a SIGKILL that left client connections open, and
still refuses a port another server listens on.

A killed server's accepted connections stay in the kernel (FIN_WAIT_2 while the client keeps
its end open, then TIME_WAIT) for tens of seconds; they hold the port for a plain ``bind``,
not for one with ``SO_REUSEADDR`` (what uvicorn itself uses), which still fails while a socket
listens on it."""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest
import typer

from tests.procs import Proc, alcove_env, free_port, http_ok, wait_until

pytestmark = pytest.mark.integration


def _keep_alive(port: int) -> socket.socket:
    """A client connection that has had one answer and stays open (HTTP/1.1 keep-alive)."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    sock.sendall(b"GET /api/v1/health HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: keep-alive\r\n\r\n")
    got = b""
    while b"\r\n\r\n" not in got:
        chunk = sock.recv(4096)
        assert chunk, f"the server closed the connection before answering: {got!r}"
        got += chunk
    assert got.startswith(b"HTTP/1.1 200"), got
    return sock


def _plain_bind_fails(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        try:
            sock.bind(("127.0.0.1", port))
        except OSError:
            return True
    return False


def test_serve_comes_up_at_once_after_a_sigkill_with_open_keep_alive_connections(tmp_path: Path) -> None:
    port = free_port()
    env = alcove_env(data_dir=str(tmp_path / "data"), log_level="WARNING")
    health = f"http://127.0.0.1:{port}/api/v1/health"
    first = Proc(["serve", "--workers", "1", "--port", str(port)], env, tmp_path / "first.log")
    second: Proc | None = None
    conns: list[socket.socket] = []
    try:
        wait_until(lambda: http_ok(health), 90, "the first alcove serve", first)
        conns = [_keep_alive(port) for _ in range(5)]
        first.kill()  # SIGKILL to its process group: no shutdown, the connections stay with the kernel
        killed = time.monotonic()
        # the situation to survive: the dead server's connections still hold the port for a plain bind
        assert _plain_bind_fails(port)
        second = Proc(["serve", "--no-migrate", "--workers", "1", "--port", str(port)], env, tmp_path / "second.log")
        wait_until(lambda: http_ok(health), 60, "the restarted alcove serve", second)
        took = time.monotonic() - killed
        print(f"\nRESTART after SIGKILL with 5 open keep-alive connections: health 200 after {took:.2f} s")
    finally:
        for conn in conns:
            conn.close()
        for proc in (first, second):
            if proc is not None:
                proc.stop()


def test_the_port_check_still_refuses_a_port_a_server_listens_on() -> None:
    from alcove_worker.cli.serve import _check_port_free

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as listener:
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn does
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        with pytest.raises(typer.Exit) as exc:
            _check_port_free("127.0.0.1", listener.getsockname()[1])
        assert exc.value.exit_code == 2
