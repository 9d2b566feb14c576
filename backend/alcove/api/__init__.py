"""The shared web plumbing of every domain's router: the session dependency, errors,
parameters, response caching, downloads, health, static files, security headers. It
imports no domain; :func:`alcove.app.create_app` assembles the application from the
domain packages' routers (``alcove.<domain>.router``).

The API process stays light: it imports neither torch nor casadi (it validates with the
science package's pydantic schemas only), and sends jobs to the workers by name
(:func:`alcove.jobs.send_job`). Model artifacts with TorchScript are built by a worker in a
child process (:mod:`alcove.surrogates.artifact_zips`).
"""
