"""The application's route table, flattened (for tests, docs and the CLI)."""

from __future__ import annotations

from dataclasses import dataclass

from fastapi import FastAPI
from fastapi.routing import APIRoute, iter_route_contexts


@dataclass(frozen=True)
class RouteInfo:
    method: str
    path: str  # full path with {placeholders}
    operation_id: str
    route: APIRoute


def api_routes(app: FastAPI) -> list[RouteInfo]:
    """Every (method, path) of every API route, including those hidden from the schema."""
    out: list[RouteInfo] = []
    for ctx in iter_route_contexts(app.routes):
        route = ctx.original_route
        if not isinstance(route, APIRoute):
            continue
        path = ctx.path_format or ctx.path or route.path_format
        assert route.methods is not None  # starlette's Route allows None; an APIRoute always has them (GET by default)
        for method in sorted(route.methods - {"HEAD", "OPTIONS"}):
            out.append(RouteInfo(method, path, route.operation_id or route.name, route))
    return out


def allowed_methods(app: FastAPI, path: str) -> list[str]:
    """The methods some route of ``app`` answers at ``path`` (for the ``Allow`` header of a
    405): the union over every route whose path matches, not just the first one's. Integer
    path parameters are declared ``{name:integer}`` (:mod:`alcove.api.params`), so
    ``/tasks/presets`` does not match ``/tasks/{task_id:integer}``."""
    methods: set[str] = set()
    for ctx in iter_route_contexts(app.routes):
        route = ctx.original_route
        regex = getattr(ctx, "path_regex", None)
        if isinstance(route, APIRoute) and regex is not None and regex.match(path) and ctx.methods:
            methods |= set(ctx.methods)
    return sorted(methods)
