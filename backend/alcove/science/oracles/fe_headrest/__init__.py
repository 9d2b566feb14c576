"""``fe-headrest-2d``: a nonlinear plane-strain finite-element headrest oracle (see docs/fe-oracle.md)."""

from alcove.science.oracles.fe_headrest.oracle import FEHeadrestOracle
from alcove.science.oracles.fe_headrest.params import FEHeadrestParams
from alcove.science.oracles.fe_headrest.reference import reference_motion

__all__ = ["FEHeadrestOracle", "FEHeadrestParams", "reference_motion"]
