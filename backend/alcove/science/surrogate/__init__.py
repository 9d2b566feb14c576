"""Data-driven contact surrogate: the paper's features, two MLPs, training, the CasADi contact model, portable exports.

Import from the submodules (``features``, ``mlp``, ``config``, ``dataset``, ``training``,
``artifact``, ``casadi_contact``, ``portable``, ``preliminary``); the most used names are re-exported here.
"""

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the real names for type checkers; at run time they load on first use
    from alcove.science.surrogate.config import NetworkConfig, SurrogateConfig, SurrogateConfigError
    from alcove.science.surrogate.dataset import PoolDataError, PoolDataset, load_pool_dir, load_preliminary_csv
    from alcove.science.surrogate.mlp import MLP, SurrogateModel
    from alcove.science.surrogate.training import TrainingCancelled, TrainingResult, predict, train_surrogate

# Re-exports are resolved on first use (PEP 562) so that importing the light submodules
# (``config``) does not import torch.
_EXPORTS = {
    "NetworkConfig": "config",
    "SurrogateConfig": "config",
    "SurrogateConfigError": "config",
    "PoolDataError": "dataset",
    "PoolDataset": "dataset",
    "load_pool_dir": "dataset",
    "load_preliminary_csv": "dataset",
    "MLP": "mlp",
    "SurrogateModel": "mlp",
    "TrainingCancelled": "training",
    "TrainingResult": "training",
    "predict": "training",
    "train_surrogate": "training",
}


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(f"alcove.science.surrogate.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "MLP",
    "NetworkConfig",
    "PoolDataError",
    "PoolDataset",
    "SurrogateConfig",
    "SurrogateConfigError",
    "SurrogateModel",
    "TrainingCancelled",
    "TrainingResult",
    "load_pool_dir",
    "load_preliminary_csv",
    "predict",
    "train_surrogate",
]
