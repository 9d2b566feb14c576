"""The one error shape of the science layer: bad input, with the field it is about.

Every module raises its own subclass (a task, a pool, a config, an oracle's input...), so callers
catch what they expect; all carry ``field`` (the dotted path or the name of what is wrong) and
``reason``, which the API and the CLI report as ``<field>: <reason>``."""

from __future__ import annotations


class FieldError(ValueError):
    """Bad input; ``field`` names what is wrong and ``reason`` says why."""

    def __init__(self, field: str, reason: str):
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")

    def __reduce__(self) -> tuple[type[FieldError], tuple[str, str]]:
        return type(self), (self.field, self.reason)  # picklable (a process pool sends it back)
