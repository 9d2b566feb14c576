"""Training configuration of a surrogate (architecture and protocol), validated with pydantic.

The defaults are the paper's: force MLP 19-6-6-4-3 and moment MLP 19-6-6-6-4-3 with softplus
hidden layers, Adam with learning rate 0.01, batch size 1024, early stopping with patience 6;
70/30 split of the pool by simulation into training and test, the training part split 80/20
pointwise into train and validation. The training's arithmetic is float32 (``dtype``; the paper
does not state its precision, PyTorch's default is float32); the trained model is held and
evaluated in float64.

Sample weights: each dataset of the pool carries an optional weight; without one, its weight
comes from its origin: ``preliminary_weight`` for preliminary data (decaying by half every
``preliminary_halving`` oracle simulations in the pool, if set), 1 otherwise (oracle and
uploaded data).
This lets a campaign fade out the preliminary data as oracle data accumulates (a remedy for
the bias toward low forces the paper reports). With ``member_data: "bootstrap"`` each ensemble
member also multiplies the weights of the measured simulations of its training part by how often
a bootstrap resample over those simulations drew them (:func:`.training.bootstrap_counts`).

Inputs: ``features: "paper"`` (default) is the paper's 19 features of the state (q, qd);
``"history"`` adds the history states of :mod:`.history` (the largest indentation so far and the
low-pass filtered slip velocity of the contact point), which let the networks learn friction that
depends on the path. Such a model predicts along motions (it needs their times), not at single
states.

Architecture: ``"paper"`` (default) is the paper's: the MLPs' outputs are the wrench.
``"gated"`` (:mod:`.gated`) puts a contact-aware output layer after them: the wrench is
exactly zero where the signed gap between head profile and headrest surface is clearly open
(>= ``gate.open_gap``, 2 mm by default), the normal force fx is non-negative, and the layer is C2 in the state.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError

from alcove.science.errors import FieldError
from alcove.science.spec_checks import WholeNumber, as_whole_number, error_location, quantity, range_text
from alcove.science.surrogate.features import FEATURE_NAMES
from alcove.science.surrogate.history import HISTORY_NAMES, HistoryConfig

Activation = Literal["softplus", "tanh", "sigmoid"]
Architecture = Literal["paper", "gated"]
FeatureSet = Literal["paper", "history"]
NormalForce = Literal["shared", "own"]
#: the force net's output blocks with ``normal_force: "own"``: fx apart from (fy, fz)
NORMAL_FORCE_BLOCKS: tuple[tuple[int, ...], ...] = ((0,), (1, 2))
LayerWidth = Annotated[int, Field(ge=1, le=4096), BeforeValidator(as_whole_number)]


class SurrogateConfigError(FieldError):
    """Invalid surrogate configuration; ``field`` is the dotted path of the offending entry."""


class NetworkConfig(BaseModel):
    """One MLP: hidden layer widths and their activation (the output layer is linear)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    hidden: tuple[LayerWidth, ...] = Field(
        min_length=1,
        max_length=16,
        description="widths of the hidden layers [-]: 1 to 16 layers of 1 to 4096 units (paper: 6-6-4, 6-6-6-4)",
    )
    activation: Activation = Field("softplus", description="activation of the hidden layers")


class GateConfig(BaseModel):
    """The ``gated`` architecture's output layer: where the wrench is cut off and how soft the
    normal force's softplus is (docs/concepts.md)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    open_gap: Annotated[
        float,
        quantity("signed gap beyond which the predicted wrench is exactly zero", "m", gt=0, le=0.05, why="2 mm"),
    ] = 0.002
    blend: Annotated[
        float,
        quantity(
            "width of the smooth blend below open_gap (the gate is one for gap <= open_gap - blend)",
            "m",
            gt=0,
            le=0.05,
            why="2 mm",
        ),
    ] = 0.002
    force_width: Annotated[
        float, quantity("width of the softplus that keeps the normal force fx >= 0", "N", gt=0, le=1000, why="1 N")
    ] = 1.0


class SurrogateConfig(BaseModel):
    """Architecture and training protocol of one surrogate model pair."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    architecture: Architecture = Field(
        "paper",
        description="output layer: 'paper' (the MLPs' outputs are the wrench, the paper's) or 'gated' "
        "(the wrench is exactly zero where the head is clear of the headrest by gate.open_gap (default 2 mm), and the "
        "normal force pushes the head away; docs/concepts.md)",
    )
    gate: GateConfig = Field(
        default_factory=GateConfig, description="the gated architecture's output layer (unused by 'paper')"
    )
    features: FeatureSet = Field(
        "paper",
        description="inputs of the networks: 'paper' (the paper's 19 features of the state q, qd) or 'history' "
        "(those and the history states: the largest indentation of the contact point so far and its slip "
        "velocity along the headrest, low-pass filtered; the friction force depends on the path, docs/concepts.md)",
    )
    history: HistoryConfig = Field(
        default_factory=HistoryConfig, description="the history states' parameters (unused by the 'paper' feature set)"
    )
    force: NetworkConfig = Field(default_factory=lambda: NetworkConfig(hidden=(6, 6, 4)))
    normal_force: NormalForce = Field(
        "own",
        description="the force net's hidden layers: 'own' (the default): the normal force fx gets hidden layers of its "
        "own (the widths of 'force'), apart from those of fy and fz, so that the friction force, which depends on the "
        "path, cannot pull the normal force, which depends on the state; with the history features fx's layers take "
        "the state's features only; or 'shared' by fx and (fy, fz), the paper's (docs/concepts.md)",
    )
    moment: NetworkConfig = Field(default_factory=lambda: NetworkConfig(hidden=(6, 6, 6, 4)))
    learning_rate: Annotated[
        float, quantity("Adam learning rate (step size on standardised data)", "-", gt=0, le=1, why="paper: 0.01")
    ] = 0.01
    batch_size: WholeNumber = Field(
        1024, ge=1, le=1_000_000, description="samples per Adam step [-], a whole number from 1 to 1e6 (paper: 1024)"
    )
    patience: WholeNumber = Field(
        6,
        ge=1,
        le=1000,
        description="early stopping: epochs without a better validation loss [-], 1 to 1000 (paper: 6)",
    )
    patience_steps: WholeNumber = Field(
        200,
        ge=0,
        le=10_000_000,
        description="early stopping also waits this many Adam steps without a better validation loss [-], 0 to 1e7: "
        "a member stops after both patience epochs and patience_steps steps without improvement, so a small pool "
        "(a few batches an epoch) is not stopped after a handful of steps (0: epochs alone, the paper's rule)",
    )
    warm_learning_rate: Annotated[
        float | None,
        quantity(
            "Adam learning rate of a warm-started net (every member carries its previous weights)",
            "-",
            gt=0,
            le=1,
            why="null: learning_rate, a full training that starts from the carried weights",
        ),
    ] = None
    warm_max_epochs: Annotated[int, Field(ge=1, le=100_000), BeforeValidator(as_whole_number)] | None = Field(
        None,
        description="most epochs of a warm-started net per training [-], 1 to 100000 (at most max_epochs); "
        "null: max_epochs",
    )
    warm_patience: Annotated[int, Field(ge=1, le=1000), BeforeValidator(as_whole_number)] | None = Field(
        None,
        description="early stopping of a warm-started net: epochs without a better validation loss than its carried "
        "weights' and its later epochs' [-], 1 to 1000; null: patience",
    )
    warm_min_improvement: Annotated[
        float,
        quantity(
            "relative decrease of the best validation loss an epoch of a warm-started net must reach to count "
            "as better (the carried weights are epoch 0)",
            "-",
            ge=0,
            lt=1,
            why="0: any decrease, as in a cold training",
        ),
    ] = 0.0
    max_epochs: WholeNumber = Field(
        1000, ge=1, le=100_000, description="most epochs per training [-], a whole number from 1 to 100000"
    )
    test_fraction: Annotated[
        float,
        quantity("share of the simulations held out as test set", "-", ge=0, lt=1, why="paper: 0.3"),
    ] = 0.3
    validation_fraction: Annotated[
        float,
        quantity("pointwise share of the training part used for validation", "-", gt=0, lt=1, why="paper: 0.2"),
    ] = 0.2
    seed: WholeNumber = Field(
        0,
        ge=0,
        le=2**63 - 1,  # not lt=2**63: a JSON Schema reader in floating point takes 2**63 - 1 for 2**63
        description="seed of splits, initialisation and batch order [-], a whole number "
        + range_text("", ge=0, le=2**63 - 1),
    )
    warm_start: bool = Field(
        True, strict=True, description="start from the previous model's weights when the architecture matches"
    )
    normalize_outputs: bool = Field(
        True, strict=True, description="train on standardised targets (exported transparently)"
    )
    preliminary_weight: Annotated[
        float, quantity("sample weight of preliminary data", "-", ge=0, le=1e6, why="oracle data weigh 1")
    ] = 1.0
    preliminary_halving: float | None = Field(
        None,
        gt=0,
        le=1e6,
        description="halve the preliminary weight every this many oracle simulations in the pool [simulations], "
        f"{range_text('simulations', gt=0, le=1e6)}; null: never",
    )
    preliminary_in_contact: Literal["drop", "keep"] = Field(
        "drop",
        description="the preliminary samples in contact (the auxiliary law's wrench not zero) once the pool holds "
        "oracle or uploaded data: 'drop' (weight 0; the samples out of contact keep their weight) or 'keep' "
        "(weighted like the other preliminary samples). The auxiliary law is another material than the oracle's: "
        "where oracle data exist its contact forces contradict them, and where they do not, they pull the model "
        "towards the auxiliary law (docs/concepts.md)",
    )
    ensemble_size: WholeNumber = Field(
        5,
        ge=1,
        le=64,
        description="members K of the deep ensemble [-], 1 to 64: each with its own seed and 70/30 + 80/20 split; "
        "predictions are the members' mean and standard deviation (1: the paper's single model)",
    )
    member_data: Literal["split", "bootstrap"] = Field(
        "split",
        description="what each member of the ensemble trains on: 'split' (its own 70/30 split by simulation and "
        "80/20 pointwise split; the members see mostly the same trajectories) or 'bootstrap' (in addition, the "
        "measured simulations of its training part resampled with replacement, as many draws as there are: a "
        "simulation drawn c times weighs c times as much in its train and validation samples, one never drawn "
        "weighs 0 for that member; the preliminary data keep their weights, they are independent points of one "
        "known law, not trajectories). Members that differ in their data disagree where the data do not pin the "
        "law down, so their spread reflects it (docs/concepts.md)",
    )
    dtype: Literal["float64", "float32"] = Field(
        "float32",
        description="floating-point precision of the training arithmetic (float32: PyTorch's default, about twice "
        "as fast on the CPU); the trained networks are held, stored and evaluated "
        "in float64 (float32 weights are exact in float64), so predictions, the OCP and the exports use the same "
        "numbers",
    )

    @classmethod
    def parse(cls, data: dict[str, Any]) -> SurrogateConfig:
        """Validate a dict; errors become :class:`SurrogateConfigError` with a dotted field path."""
        try:
            return cls.model_validate(data)
        except ValidationError as exc:
            field, reason = error_location(exc.errors()[0])
            raise SurrogateConfigError(field or "config", reason) from None

    @classmethod
    def from_json(cls, source: str | Path) -> SurrogateConfig:
        """Read a JSON file (path) or JSON text."""
        if isinstance(source, Path) or not str(source).lstrip().startswith("{"):
            try:
                text = Path(source).read_text()
            except (FileNotFoundError, IsADirectoryError, UnicodeDecodeError) as exc:
                raise SurrogateConfigError("config", f"cannot read {source}: {type(exc).__name__}") from None
        else:
            text = str(source)
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise SurrogateConfigError("config", f"not valid JSON: {exc.msg} at line {exc.lineno}") from None
        if not isinstance(data, dict):
            raise SurrogateConfigError("config", "must be a JSON object")
        return cls.parse(data)

    def output_blocks(self, net: str) -> tuple[tuple[int, ...], ...]:
        """The output blocks of net ``net`` (``force`` or ``moment``): groups of outputs with hidden
        layers of their own (:class:`alcove.science.surrogate.mlp.MLP`); none: one net for all."""
        return NORMAL_FORCE_BLOCKS if net == "force" and self.normal_force == "own" else ()

    def block_inputs(self, net: str) -> tuple[tuple[int, ...] | None, ...]:
        """The inputs of each output block of net ``net``: the normal force's block takes the state's
        features only (it depends on the state, not on the path: the history states would only let it
        extrapolate), the tangential block every input."""
        if not self.output_blocks(net):
            return ()
        state_only = None if self.features == "paper" else tuple(range(len(FEATURE_NAMES)))
        return (state_only, None)

    @property
    def input_names(self) -> tuple[str, ...]:
        """The networks' inputs, in order: the 19 features, then the history states if any."""
        return FEATURE_NAMES + (HISTORY_NAMES if self.features == "history" else ())

    @property
    def warm_rule(self) -> tuple[float, int, int, float]:
        """The warm start's learning rate, most epochs, patience and least improvement, unset ones from the
        cold training's."""
        return (
            self.learning_rate if self.warm_learning_rate is None else self.warm_learning_rate,
            self.max_epochs if self.warm_max_epochs is None else min(self.warm_max_epochs, self.max_epochs),
            self.patience if self.warm_patience is None else self.warm_patience,
            self.warm_min_improvement,
        )

    def weight_for(self, origin: str, n_oracle: int) -> float:
        """Default sample weight of a dataset of ``origin`` in a pool holding ``n_oracle`` oracle simulations."""
        if origin != "preliminary":
            return 1.0
        w = self.preliminary_weight
        if self.preliminary_halving is not None:
            w *= 0.5 ** (n_oracle / self.preliminary_halving)
        return w


__all__ = [
    "NORMAL_FORCE_BLOCKS",
    "Activation",
    "Architecture",
    "FeatureSet",
    "GateConfig",
    "NetworkConfig",
    "NormalForce",
    "SurrogateConfig",
    "SurrogateConfigError",
]
