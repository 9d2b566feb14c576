"""File downloads: the response and its OpenAPI description."""

from __future__ import annotations

from typing import Any

from fastapi import Response


def binary(*media_types: str) -> dict[str, Any]:
    """``responses=`` entry of a route answering with a file of one of ``media_types``."""
    schema = {"type": "string", "format": "binary"}
    return {"content": {m: {"schema": schema} for m in media_types}, "description": "file download"}


def download(data: bytes, filename: str, media_type: str) -> Response:
    return Response(
        content=data, media_type=media_type, headers={"Content-Disposition": f'attachment; filename="{filename}"'}
    )
