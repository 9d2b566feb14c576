"""Pure science: multibody model, OCP, oracles, features, MLPs, sampling.

Nothing in this package may import the web layer, the database layer or Celery.
"""
