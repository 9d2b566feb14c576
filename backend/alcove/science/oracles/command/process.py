"""Running an external command: its own process group, a wall-time limit, cooperative cancellation.

The command is an argument list (never a shell string). It runs in its own session, so a
timeout or a cancellation ends the solver and every process it started (SIGTERM to the
group, SIGKILL after a grace period); an exception in the caller (KeyboardInterrupt) does
too. Standard output and error go to files in the working directory.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from alcove.science.oracles.base import CancelCheck, OracleCancelled

POLL_SECONDS = 0.05
TERMINATE_GRACE_SECONDS = 3.0


@dataclass(frozen=True)
class ProcessOutcome:
    """How the command ended: its exit code (None if it never started or was killed on a
    timeout) and, unless it exited with code 0, why the run failed."""

    exit_code: int | None
    failure: str | None = None


def run_process(
    argv: Sequence[str],
    workdir: Path,
    env: Mapping[str, str],
    timeout_s: float,
    stdout_path: Path,
    stderr_path: Path,
    cancel: CancelCheck | None = None,
    cancelled_message: str = "cancelled",
) -> ProcessOutcome:
    """Run ``argv`` in ``workdir`` until it exits, ``timeout_s`` passes or ``cancel()`` turns true.

    A cancellation raises :class:`OracleCancelled` with ``cancelled_message`` after the
    process group is ended.
    """
    with open(stdout_path, "wb") as out, open(stderr_path, "wb") as err:
        try:
            proc = subprocess.Popen(
                list(argv),
                cwd=workdir,
                env=dict(env),
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=err,
                start_new_session=True,  # own process group: a timeout kills the solver and its children
            )
        except OSError as exc:
            return ProcessOutcome(None, f"cannot start {argv[0]!r}: {exc.strerror or exc}")
        deadline = time.monotonic() + timeout_s
        try:
            while True:
                try:
                    code = proc.wait(timeout=POLL_SECONDS)
                    break
                except subprocess.TimeoutExpired:
                    pass
                if cancel is not None and cancel():
                    kill_process_group(proc)
                    raise OracleCancelled(cancelled_message)
                if time.monotonic() > deadline:
                    kill_process_group(proc)
                    return ProcessOutcome(None, f"timeout: the command ran longer than {timeout_s:g} s and was killed")
        except BaseException:
            kill_process_group(proc)  # KeyboardInterrupt, cancellation: never leave the solver running
            raise
    if code < 0:
        return ProcessOutcome(code, f"the command was killed by signal {signal_name(-code)}")
    if code != 0:
        last = tail(stderr_path, lines=1)
        return ProcessOutcome(code, f"the command exited with code {code}" + (f": {last}" if last else ""))
    return ProcessOutcome(0)


def kill_process_group(proc: subprocess.Popen[bytes]) -> None:
    """SIGTERM to the command's process group, SIGKILL after a grace period."""
    for sig, grace in ((signal.SIGTERM, TERMINATE_GRACE_SECONDS), (signal.SIGKILL, None)):
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, sig)
        try:
            proc.wait(timeout=grace)
            # the leader is gone; make sure no child of it survives in the group
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(proc.pid, signal.SIGKILL)
            return
        except subprocess.TimeoutExpired:
            continue


def signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return str(number)


def tail(path: Path, lines: int = 20) -> str:
    """The last ``lines`` lines of a text file ("" if it cannot be read)."""
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return ""
    return "\n".join(text.strip().splitlines()[-lines:])


__all__ = [
    "POLL_SECONDS",
    "TERMINATE_GRACE_SECONDS",
    "ProcessOutcome",
    "kill_process_group",
    "run_process",
    "signal_name",
    "tail",
]
