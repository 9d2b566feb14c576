"""alcove: active-learning campaigns for data-driven contact surrogates."""

__version__ = "0.1.0"
