"""Campaign, iteration, pool-version and model-version routes (on the campaign engine's services)."""

from __future__ import annotations

from fastapi import APIRouter


def routers() -> list[APIRouter]:
    return []
