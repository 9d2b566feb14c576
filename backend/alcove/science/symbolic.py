"""The type of CasADi symbolic expressions in science code (for annotations).

Kinematics, features and contact models are written once with CasADi operations and built
either as SX (scalar graphs: exact, fast derivatives) or MX (matrix graphs: fast to build).
A function generic in :data:`Symbolic` takes and returns the same kind.
"""

from __future__ import annotations

from typing import TypeVar

import casadi as ca

Symbolic = TypeVar("Symbolic", ca.SX, ca.MX)

__all__ = ["Symbolic"]
