"""Thin worker layer: the Celery app, job wrappers calling backend services, the CLI."""
