"""Data-driven contact surrogate: the paper's features, two MLPs, training, export.

Import from the submodules (``features``, ``mlp``, ``config``, ``dataset``, ``training``,
``artifact``, ``export``, ``preliminary``); the most used names are re-exported here.
"""

from alcove.science.surrogate.config import NetworkConfig, SurrogateConfig, SurrogateConfigError
from alcove.science.surrogate.dataset import PoolDataError, PoolDataset, load_pool_dir, load_preliminary_csv
from alcove.science.surrogate.mlp import MLP, SurrogateModel
from alcove.science.surrogate.training import TrainingCancelled, TrainingResult, predict, train_surrogate

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
