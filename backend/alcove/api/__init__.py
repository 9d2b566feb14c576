"""The HTTP API (FastAPI). ``create_app()`` builds it from the domain packages' routers
(``alcove.<domain>.router``); this package holds the shared web plumbing (auth, session
dependency, errors, parameters, response caching, downloads, health, static files).

The API process stays light: it imports neither torch nor casadi (it validates with the
science package's pydantic schemas only), and sends jobs to the workers by name
(:func:`alcove.jobs.send_job`). Model artifacts with TorchScript are built in a child
process (:mod:`alcove.surrogates.artifact_export`).
"""

from alcove.api.app import create_app

__all__ = ["create_app"]
