"""Model artifact zips (surrogate JSON + TorchScript + CasADi + ONNX), built in a child process.

Neither the API process nor a worker's job process imports torch for them: :func:`build_zips`
runs ``python -m alcove.surrogates.artifact_zips OUT_DIR ID...`` once for the model versions
whose zip is not stored yet (a worker's artifact build, :mod:`alcove.surrogates.artifact_build_worker`,
or the CLI). Artifacts are immutable, so a zip is stored by the SHA-256 of the artifact JSON and
the zip layout (``ZIP_LAYOUT``: 2 added the CASADI and ONNX exports) under
``ALCOVE_DATA_DIR/artifacts/model-zips``. A zip is written to a temporary file and renamed into
place, so a full or read-only folder leaves the stored zips as they were.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from alcove.api.artifacts_folder import require_writable, storage_error
from alcove.errors import Conflict
from alcove.models import ModelVersion
from alcove.settings import get_settings

BUILD_TIMEOUT_S = 600
ZIP_LAYOUT = 2  # bump when the zip's content changes, so that stored zips are rebuilt
#: The child's exit status when it cannot store a zip (the artifacts folder is full or read-only).
EXIT_STORAGE = 3
#: The child's line on stdout for each zip it stored.
BUILT = "built"


class BuildFailed(RuntimeError):
    """The child process did not build every zip; the message says why."""


def zips_dir() -> Path:
    return get_settings().artifacts_dir / "model-zips"


def cache_dir() -> Path:
    """:func:`zips_dir`, created if missing."""
    d = zips_dir()
    d.mkdir(parents=True, exist_ok=True)
    return d


def zip_path(mv: ModelVersion) -> Path:
    if mv.artifact_sha256 is None:
        raise Conflict(f"model version {mv.version} has no artifact")
    return zips_dir() / f"{mv.artifact_sha256}.v{ZIP_LAYOUT}.zip"


def missing_zips(versions: Sequence[ModelVersion]) -> list[ModelVersion]:
    """The versions whose zip is not stored yet."""
    return [mv for mv in versions if not zip_path(mv).is_file()]


def stored_zip_paths(versions: Sequence[ModelVersion]) -> dict[int, Path]:
    """Model version id -> path of its stored zip (409 if one is not built: build it first)."""
    missing = missing_zips(versions)
    if missing:
        raise Conflict(f"the artifact zip of model version {missing[0].version} is not built yet: ask again")
    return {mv.id: zip_path(mv) for mv in versions}


def build_zips(ids: Sequence[int], on_built: Callable[[int], None] = lambda _: None) -> None:
    """Build the zips of model versions ``ids`` in one child process; ``on_built(id)`` after each
    is stored. Raises :class:`~alcove.errors.StorageUnavailable` (the folder cannot take them:
    checked before the child starts, and reported by the child) or :class:`BuildFailed`."""
    if not ids:
        return
    out_dir = zips_dir()
    require_writable(out_dir, "cannot build the model artifact zips")
    env = {**os.environ, "ALCOVE_DATABASE_URL": get_settings().database_url}
    cmd = [sys.executable, "-m", "alcove.surrogates.artifact_zips", str(out_dir), *map(str, ids)]
    with subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        try:
            assert proc.stdout is not None and proc.stderr is not None
            for line in proc.stdout:
                word, _, ident = line.strip().partition(" ")
                if word == BUILT and ident.isdigit():
                    on_built(int(ident))
            proc.wait(timeout=BUILD_TIMEOUT_S)
            stderr = proc.stderr.read()
        except BaseException:
            proc.kill()
            raise
    if proc.returncode == EXIT_STORAGE:
        require_writable(out_dir, "cannot store the model artifact zips")  # names the cause (full, read-only)
        raise BuildFailed(stderr.strip()[-2000:])
    if proc.returncode != 0:
        raise BuildFailed(f"building model artifacts failed (exit status {proc.returncode}): {stderr[-2000:]}")


def main(argv: list[str]) -> int:
    from alcove.db import open_transaction
    from alcove.surrogates.service import model_artifact_bytes

    out_dir = Path(argv[0])
    with open_transaction() as s:
        for ident in map(int, argv[1:]):
            mv = s.get(ModelVersion, ident)
            assert mv is not None and mv.artifact_sha256, f"model version {ident} has no artifact"
            data = model_artifact_bytes(s, mv)
            tmp = out_dir / f".{mv.artifact_sha256}.{os.getpid()}.tmp"
            try:
                tmp.write_bytes(data)
                tmp.replace(out_dir / f"{mv.artifact_sha256}.v{ZIP_LAYOUT}.zip")
            except OSError as err:
                with contextlib.suppress(OSError):  # a read-only folder refuses even this
                    tmp.unlink(missing_ok=True)
                print(storage_error(out_dir, err, f"cannot store model version {ident}'s zip").message, file=sys.stderr)
                return EXIT_STORAGE
            print(f"{BUILT} {ident}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
