"""Named NumPy arrays <-> content-addressed, compressed ``.npz`` blobs.

``encode_arrays`` writes a deterministic ``.npz`` (fixed zip timestamps, sorted names,
deflate). The key is the SHA-256 of the canonical content (for each array in name order:
name, dtype, shape, C-order bytes), so the same arrays always map to the same
:class:`~alcove.models.Blob` row whatever the compression. Object arrays are refused.
"""

from __future__ import annotations

import hashlib
import io
import zipfile
from collections.abc import Mapping
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from alcove.models.data import Blob

NPZ_MEDIA_TYPE = "application/x-npz"
_ZIP_EPOCH = (1980, 1, 1, 0, 0, 0)


def _prepare(arrays: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    if not arrays:
        raise ValueError("no arrays given")
    out: dict[str, np.ndarray] = {}
    for name in sorted(arrays):
        if not isinstance(name, str) or not name or "/" in name:
            raise ValueError(f"bad array name {name!r}")
        a = np.ascontiguousarray(np.asarray(arrays[name]))
        if a.dtype.hasobject:
            raise ValueError(f"array {name!r} has dtype object; only numeric/bool/fixed-size string arrays are stored")
        out[name] = a
    return out


def content_hash(arrays: Mapping[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name, a in _prepare(arrays).items():
        h.update(name.encode() + b"\0" + a.dtype.str.encode() + b"\0" + repr(a.shape).encode() + b"\0")
        h.update(a.tobytes(order="C"))
    return h.hexdigest()


def encode_arrays(arrays: Mapping[str, np.ndarray]) -> bytes:
    """Deterministic compressed ``.npz`` bytes (readable with ``np.load``)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=6) as zf:
        for name, a in _prepare(arrays).items():
            info = zipfile.ZipInfo(name + ".npy", date_time=_ZIP_EPOCH)
            info.compress_type = zipfile.ZIP_DEFLATED
            member = io.BytesIO()
            np.lib.format.write_array(member, a, allow_pickle=False)
            zf.writestr(info, member.getvalue())
    return buf.getvalue()


def decode_arrays(data: bytes) -> dict[str, np.ndarray]:
    with np.load(io.BytesIO(data), allow_pickle=False) as npz:
        return {k: npz[k] for k in npz.files}


def manifest(arrays: Mapping[str, np.ndarray]) -> dict[str, dict[str, object]]:
    return {k: {"dtype": a.dtype.str, "shape": list(a.shape)} for k, a in _prepare(arrays).items()}


def put_arrays(session: Session, arrays: Mapping[str, np.ndarray]) -> str:
    """Store ``arrays`` once (content hash) and return the hash; no-op if already stored.

    Under concurrency two transactions may insert the same hash; the loser gets an
    IntegrityError at commit and should simply retry its transaction.
    """
    key = content_hash(arrays)
    if session.get(Blob, key) is None:
        data = encode_arrays(arrays)
        session.add(
            Blob(sha256=key, media_type=NPZ_MEDIA_TYPE, size_bytes=len(data), manifest=manifest(arrays), data=data)
        )
        session.flush()
    return key


def get_arrays(session: Session, sha256: str) -> dict[str, np.ndarray]:
    data = session.execute(select(Blob.data).where(Blob.sha256 == sha256)).scalar_one_or_none()
    if data is None:
        raise KeyError(f"no blob {sha256}")
    return decode_arrays(data)


def put_bytes(session: Session, data: bytes, media_type: str, manifest_: dict[str, Any] | None = None) -> str:
    """Store opaque bytes (e.g. a model artifact zip) by the SHA-256 of the bytes."""
    key = hashlib.sha256(data).hexdigest()
    if session.get(Blob, key) is None:
        session.add(Blob(sha256=key, media_type=media_type, size_bytes=len(data), manifest=manifest_ or {}, data=data))
        session.flush()
    return key


def get_bytes(session: Session, sha256: str) -> bytes:
    data = session.execute(select(Blob.data).where(Blob.sha256 == sha256)).scalar_one_or_none()
    if data is None:
        raise KeyError(f"no blob {sha256}")
    return data
