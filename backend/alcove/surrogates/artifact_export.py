"""Build model artifact zips (surrogate JSON + TorchScript) in a child process.

The API process never imports torch: ``artifact_zip_paths`` runs
``python -m alcove.surrogates.artifact_export OUT_DIR ID...`` once for the model versions whose
zip is not cached yet. Artifacts are immutable, so a zip is cached by the SHA-256 of the
artifact JSON and the zip layout (``ZIP_LAYOUT``: 2 added the CASADI and ONNX exports) under
``ALCOVE_DATA_DIR/artifacts/model-zips``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from alcove.errors import Conflict
from alcove.models import ModelVersion
from alcove.settings import get_settings

BUILD_TIMEOUT_S = 600
ZIP_LAYOUT = 2  # bump when the zip's content changes, so that cached zips are rebuilt


def cache_dir() -> Path:
    d = get_settings().artifacts_dir / "model-zips"
    d.mkdir(parents=True, exist_ok=True)
    return d


def artifact_zip_paths(versions: list[ModelVersion]) -> dict[int, Path]:
    """Model version id -> path of its artifact zip (built in one child process if needed)."""
    out: dict[int, Path] = {}
    missing: list[int] = []
    for mv in versions:
        if mv.artifact_sha256 is None:
            raise Conflict(f"model version {mv.version} has no artifact")
        path = cache_dir() / f"{mv.artifact_sha256}.v{ZIP_LAYOUT}.zip"
        out[mv.id] = path
        if not path.is_file():
            missing.append(mv.id)
    if missing:
        env = {**os.environ, "ALCOVE_DATABASE_URL": get_settings().database_url}
        proc = subprocess.run(
            [sys.executable, "-m", "alcove.surrogates.artifact_export", str(cache_dir()), *map(str, missing)],
            env=env,
            capture_output=True,
            text=True,
            timeout=BUILD_TIMEOUT_S,
        )
        if proc.returncode != 0:
            raise RuntimeError(f"building model artifacts failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return out


def main(argv: list[str]) -> int:
    from alcove.db import session_scope
    from alcove.surrogates.service import model_artifact_bytes

    out_dir = Path(argv[0])
    with session_scope() as s:
        for ident in map(int, argv[1:]):
            mv = s.get(ModelVersion, ident)
            assert mv is not None and mv.artifact_sha256, f"model version {ident} has no artifact"
            data = model_artifact_bytes(s, mv)
            tmp = out_dir / f".{mv.artifact_sha256}.{os.getpid()}.tmp"
            tmp.write_bytes(data)
            tmp.replace(out_dir / f"{mv.artifact_sha256}.v{ZIP_LAYOUT}.zip")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
