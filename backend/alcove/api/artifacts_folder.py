"""The artifacts folder (``ALCOVE_DATA_DIR/artifacts``): where the model artifact zips that
downloads serve are kept. Before anything is built into it, :func:`require_writable` checks in
milliseconds that it can take a file, so a full or read-only folder is answered at once (507 or
503, naming the folder and the cause) instead of after a build that cannot be stored; readiness
reports the same check (:func:`describe`)."""

from __future__ import annotations

import errno
import os
import shutil
import uuid
from pathlib import Path

from alcove.errors import StorageUnavailable
from alcove.settings import get_settings

#: A build needs at least this much free space (a zip of a five-member ensemble with its
#: TorchScript, CasADi and ONNX exports is a few MB; the margin keeps the disk from filling).
MIN_FREE_BYTES = 64 * 1024 * 1024

_FULL = (errno.ENOSPC, errno.EDQUOT)


def artifacts_dir() -> Path:
    return get_settings().artifacts_dir


def _cause(err: OSError) -> str:
    if err.errno == errno.EROFS:
        return "is on a read-only file system"
    if err.errno in (errno.EACCES, errno.EPERM):
        return "is not writable by this process (permission denied)"
    if err.errno in _FULL:
        return "is full (no space left on the device)"
    if err.errno in (errno.ENOTDIR, errno.EEXIST):
        return "is not a folder"
    return f"cannot be written ({err.strerror or err})"


def storage_error(folder: Path, err: OSError, what: str = "") -> StorageUnavailable:
    """``err`` (raised writing into ``folder``) as the error a client gets."""
    lead = f"{what}: " if what else ""
    return StorageUnavailable(f"{lead}the artifacts folder {folder} {_cause(err)}", full=err.errno in _FULL)


def require_writable(folder: Path, what: str = "") -> None:
    """Raise :class:`StorageUnavailable` unless ``folder`` (created if missing) takes a small
    file and has :data:`MIN_FREE_BYTES` free. ``what`` says what could not be done."""
    probe = folder / f".write-probe.{uuid.uuid4().hex}"  # its own name: probes of concurrent requests do not meet
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        try:
            os.write(fd, b"alcove")
        finally:
            os.close(fd)
        os.unlink(probe)
        free = shutil.disk_usage(folder).free
    except OSError as err:
        raise storage_error(folder, err, what) from err
    if free < MIN_FREE_BYTES:
        lead = f"{what}: " if what else ""
        raise StorageUnavailable(
            f"{lead}the artifacts folder {folder} is full ({free // 2**20} MiB free, a build needs at least "
            f"{MIN_FREE_BYTES // 2**20} MiB)",
            full=True,
        )


def describe() -> str:
    """For readiness: the folder, that it takes a write and its free space (raises if it does not)."""
    folder = artifacts_dir()
    require_writable(folder)
    return f"{folder} writable, {shutil.disk_usage(folder).free / 2**30:.1f} GiB free"
