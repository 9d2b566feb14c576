"""The history states of a contact model with memory, as the OCP takes them.

A surrogate of the ``history`` feature set (:mod:`alcove.science.surrogate.history`) takes its
history states as an input ``z``; the transcription (:mod:`.dmocc`) carries them as discrete
states with their recursion, from the two functions held here (built by
:func:`alcove.science.surrogate.export.surrogate_history`). Its own module so that the surrogate
exports can name it without importing the contact models (which load surrogates)."""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca


@dataclass(frozen=True)
class ContactHistory:
    """The history states of a contact model with memory: ``step`` ``(z, q, qd, dt) -> z_next``
    (the states at the next sample, from the state there and the time since the last sample)
    and ``steady`` ``(q, qd) -> z`` (the states of the first sample)."""

    step: ca.Function
    steady: ca.Function

    @property
    def size(self) -> int:
        return int(self.steady.size1_out(0))


__all__ = ["ContactHistory"]
