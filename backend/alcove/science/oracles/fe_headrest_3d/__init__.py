"""``fe-headrest-3d-ccx``: a 3D head-headrest model in CalculiX behind the command oracle (docs/fe-oracle.md)."""

from alcove.science.oracles.fe_headrest_3d.oracle import CcxHeadrestOracle, ccx_available
from alcove.science.oracles.fe_headrest_3d.params import CcxHeadrestParams

__all__ = ["CcxHeadrestOracle", "CcxHeadrestParams", "ccx_available"]
