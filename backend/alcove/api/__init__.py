"""The HTTP API (FastAPI). ``create_app()`` builds it; routers live in this package.

The API process stays light: it imports neither torch nor casadi nor the science code,
and sends jobs to the workers by name (:func:`alcove.jobs.send_job`).
"""

from alcove.api.app import create_app

__all__ = ["create_app"]
