"""File downloads: the response and its OpenAPI description."""

from __future__ import annotations

from fastapi import Response

#: ``responses=`` entry of a route answering with a file.
BINARY = {
    "content": {"application/octet-stream": {"schema": {"type": "string", "format": "binary"}}},
    "description": "file download",
}


def download(data: bytes, filename: str, media_type: str) -> Response:
    return Response(
        content=data, media_type=media_type, headers={"Content-Disposition": f'attachment; filename="{filename}"'}
    )
