"""The two PyTorch MLPs of a surrogate and the model pair with its normalisation.

``MLP``: Linear layers with a smooth activation on the hidden layers and an identity
output. Softplus is ``log1p(exp(x))`` switching to ``x`` only above x = 40, where the two
agree to double precision (log1p(exp(-40)) = 4e-18 < ulp(40) / 2); ``torch.nn.Softplus``
switches at x = 20, an error of 2e-9 that would break the 1e-10 parity with the CasADi
rebuild (``max(x, 0) + log1p(exp(-|x|))``).

``SurrogateModel``: force and moment nets, the input standardisation (mean, scale per
feature, from the training split) and the output standardisation; ``__call__`` maps raw
features (n, 19) to force (n, 3) and moment (n, 3) in the headrest frame. With the ``gated``
architecture (:attr:`SurrogateModel.gate`) the de-standardised outputs go through the
contact-aware output layer of :mod:`.gated`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch
from torch import nn

from alcove.science.arrays import FloatArray
from alcove.science.geometry import HeadNeckPreset
from alcove.science.surrogate.config import NetworkConfig, SurrogateConfig
from alcove.science.surrogate.features import N_FEATURES
from alcove.science.surrogate.gated import Gate, gap_from_features, gate_params, gate_value, gated_net_output_torch

N_OUTPUTS = 3
SOFTPLUS_THRESHOLD = 40.0
PREDICT_CHUNK = 4096  # samples per batched forward in prediction


class Softplus(nn.Module):
    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return nn.functional.softplus(x, beta=1.0, threshold=SOFTPLUS_THRESHOLD)


_ACTIVATIONS: dict[str, type[nn.Module]] = {"softplus": Softplus, "tanh": nn.Tanh, "sigmoid": nn.Sigmoid}


class MLP(nn.Module):
    """``n_in -> hidden[0] -> ... -> hidden[-1] -> n_out`` with ``activation`` on hidden layers.

    ``blocks``: groups of outputs (indices) that get hidden layers of their own, e.g. ``((0,), (1, 2))``:
    each block is an MLP of the widths ``hidden`` from its inputs to its outputs, and the net is their
    union: one MLP of widths ``len(blocks) * hidden`` whose weights between blocks are exactly zero
    (:meth:`masks`). ``block_inputs``: per block, the inputs (indices) it takes (None: all). The exports
    and the OCP's derivatives see an ordinary MLP; training keeps the zeros (the gradient is masked, so
    Adam never moves them). Empty: one dense MLP, the paper's."""

    def __init__(
        self,
        hidden: tuple[int, ...] | list[int],
        activation: str = "softplus",
        n_in: int = N_FEATURES,
        n_out: int = N_OUTPUTS,
        dtype: torch.dtype = torch.float64,
        blocks: tuple[tuple[int, ...], ...] | list[list[int]] = (),
        block_inputs: tuple[tuple[int, ...] | None, ...] | list[list[int] | None] = (),
    ):
        super().__init__()
        if activation not in _ACTIVATIONS:
            raise ValueError(f"activation: unknown {activation!r}, expected one of {sorted(_ACTIVATIONS)}")
        self.hidden = tuple(int(h) for h in hidden)
        self.activation = activation
        self.blocks = tuple(tuple(int(j) for j in b) for b in blocks)
        if self.blocks and sorted(j for b in self.blocks for j in b) != list(range(n_out)):
            raise ValueError(f"blocks: {self.blocks} must split the outputs 0..{n_out - 1}, each once")
        self.block_inputs = tuple(None if i is None else tuple(int(j) for j in i) for i in block_inputs)
        if self.block_inputs and len(self.block_inputs) != len(self.blocks):
            raise ValueError(f"block_inputs: one entry per block ({len(self.blocks)}), got {len(self.block_inputs)}")
        for inputs in self.block_inputs:
            if inputs is not None and (not inputs or not all(0 <= j < n_in for j in inputs)):
                raise ValueError(f"block_inputs: {inputs} must be inputs among 0..{n_in - 1}")
        n_blocks = max(1, len(self.blocks))
        widths = (n_in, *(h * n_blocks for h in self.hidden), n_out)
        layers: list[nn.Module] = []
        for i, (a, b) in enumerate(itertools.pairwise(widths)):
            layers.append(nn.Linear(a, b, dtype=dtype))
            if i < len(widths) - 2:
                layers.append(_ACTIVATIONS[activation]())
        self.layers = nn.Sequential(*layers)

    @classmethod
    def from_config(
        cls,
        cfg: NetworkConfig,
        dtype: torch.dtype = torch.float64,
        n_in: int = N_FEATURES,
        blocks: tuple[tuple[int, ...], ...] = (),
        block_inputs: tuple[tuple[int, ...] | None, ...] = (),
    ) -> MLP:
        return cls(cfg.hidden, cfg.activation, n_in=n_in, dtype=dtype, blocks=blocks, block_inputs=block_inputs)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        out: torch.Tensor = self.layers(x)
        return out

    def linears(self) -> list[nn.Linear]:
        return [m for m in self.layers if isinstance(m, nn.Linear)]

    def masks(self) -> list[torch.Tensor] | None:
        """Per layer, the weights that may be non-zero (1) and those between blocks (0), shaped like
        the layer's weight; None without blocks. The first layer takes a block's inputs (``block_inputs``)."""
        if not self.blocks:
            return None
        nb = len(self.blocks)
        linears = self.linears()
        out: list[torch.Tensor] = []
        for i, lin in enumerate(linears):
            mask = torch.zeros_like(lin.weight)
            if i == 0:
                h_out = lin.out_features // nb
                for b in range(nb):
                    inputs = self.block_inputs[b] if self.block_inputs else None
                    mask[b * h_out : (b + 1) * h_out, slice(None) if inputs is None else list(inputs)] = 1.0
            elif i < len(linears) - 1:
                h_out, h_in = lin.out_features // nb, lin.in_features // nb
                for b in range(nb):
                    mask[b * h_out : (b + 1) * h_out, b * h_in : (b + 1) * h_in] = 1.0
            else:
                h_in = lin.in_features // nb
                for b, outputs in enumerate(self.blocks):
                    mask[list(outputs), b * h_in : (b + 1) * h_in] = 1.0
            out.append(mask)
        return out

    def reset_parameters(self, generator: torch.Generator) -> None:
        """PyTorch's default Linear initialisation, U(-1/sqrt(fan_in), 1/sqrt(fan_in)),
        drawn from ``generator`` so that the global RNG is never touched. With blocks, fan_in is a
        unit's inputs within its block (each block starts as the MLP it stands for), and the
        weights between blocks are zero."""
        masks = self.masks()
        with torch.no_grad():
            for i, lin in enumerate(self.linears()):
                # a unit's inputs: the first layer's row of the mask (all inputs without blocks)
                fan_in = lin.in_features if masks is None else int(masks[i][0].sum())
                bound = 1.0 / np.sqrt(fan_in)
                nn.init.uniform_(lin.weight, -bound, bound, generator=generator)
                nn.init.uniform_(lin.bias, -bound, bound, generator=generator)
                if masks is not None:
                    # each unit's bound from its own fan-in within its block
                    rows = masks[i].sum(1, keepdim=True).clamp(min=1.0)
                    lin.weight.mul_(masks[i] * torch.sqrt(fan_in / rows))

    def same_architecture(self, other: MLP) -> bool:
        return (
            self.hidden == other.hidden
            and self.activation == other.activation
            and self.blocks == other.blocks
            and self.block_inputs == other.block_inputs
        )


@dataclass
class Standardization:
    """``z = (x - mean) / scale``, ``x = z * scale + mean``.

    A column constant on the training data (planar motion makes r_y, v_y, T_10, ...
    constant; fy, mx, mz vanish) must not give NaN or inf: ``fit`` gives it the scale
    ``constant_scale``: 1 for inputs (the column is only centred), 0 for outputs (the
    prediction is exactly the constant). :meth:`divisor` is the safe scale to divide by.
    """

    mean: FloatArray
    scale: FloatArray

    @classmethod
    def fit(cls, x: FloatArray, constant_scale: float = 1.0, rel_tol: float = 1e-12) -> Standardization:
        mean = x.mean(axis=0)
        std = x.std(axis=0)
        constant = std <= rel_tol * np.maximum(1.0, np.abs(mean))
        return cls(mean=mean, scale=np.where(constant, constant_scale, std))

    @property
    def divisor(self) -> FloatArray:
        return np.where(self.scale == 0, 1.0, self.scale)

    @classmethod
    def identity(cls, n: int) -> Standardization:
        return cls(np.zeros(n), np.ones(n))

    def to_dict(self) -> dict[str, list[float]]:
        return {"mean": self.mean.tolist(), "scale": self.scale.tolist()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Standardization:
        return cls(np.asarray(d["mean"], float), np.asarray(d["scale"], float))


@dataclass
class Member:
    """One member of an ensemble: its force and moment nets and the standardisations of its split."""

    force_net: MLP
    moment_net: MLP
    input_norm: Standardization
    force_norm: Standardization
    moment_norm: Standardization

    def predict_features(self, x: FloatArray, gate: Gate | None = None) -> tuple[FloatArray, FloatArray]:
        """Force (n, 3) and moment (n, 3) of this member for raw features x (n, 19); ``gate``: the
        ``gated`` architecture's output layer (None: the paper's)."""
        dtype = next(self.force_net.parameters()).dtype
        z = torch.as_tensor((np.asarray(x, float) - self.input_norm.mean) / self.input_norm.divisor, dtype=dtype)
        with torch.no_grad():
            f = self.force_net(z).double().numpy()
            m = self.moment_net(z).double().numpy()
        f, m = f * self.force_norm.scale + self.force_norm.mean, m * self.moment_norm.scale + self.moment_norm.mean
        if gate is None:
            return f, m
        g = torch.as_tensor(gate_value(gap_from_features(x, gate.profile), gate.params)[:, None])
        return (
            gated_net_output_torch("force", torch.as_tensor(f), g, gate.params, axis=1).numpy(),
            gated_net_output_torch("moment", torch.as_tensor(m), g, gate.params, axis=1).numpy(),
        )


@dataclass
class Prediction:
    """Ensemble mean and standard deviation (population, over the K members) per output."""

    force: FloatArray  # (n, 3)
    moment: FloatArray  # (n, 3)
    force_std: FloatArray  # (n, 3), zeros for K = 1
    moment_std: FloatArray


@dataclass
class SurrogateModel:
    """A trained surrogate: an ensemble of K force/moment MLP pairs with normalisation, geometry, lineage.

    ``force_net`` ... ``moment_norm`` are member 0 (with K = 1 the paper's single model);
    ``extra_members`` are members 1 .. K-1. Predictions are the ensemble mean (and std).
    """

    force_net: MLP
    moment_net: MLP
    input_norm: Standardization
    force_norm: Standardization
    moment_norm: Standardization
    config: SurrogateConfig
    preset: HeadNeckPreset
    ndof: int = 1
    lineage: dict[str, Any] = field(default_factory=dict)
    extra_members: list[Member] = field(default_factory=list)
    _stacked: _StackedEnsemble | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def dtype(self) -> torch.dtype:
        return next(self.force_net.parameters()).dtype

    @property
    def architecture(self) -> str:
        return self.config.architecture

    @property
    def gate(self) -> Gate | None:
        """The gated architecture's output layer (the config's gate, the preset's head profile); None for ``paper``."""
        return Gate(gate_params(self.config), self.preset.profile) if self.config.architecture == "gated" else None

    @property
    def members(self) -> list[Member]:
        first = Member(self.force_net, self.moment_net, self.input_norm, self.force_norm, self.moment_norm)
        return [first, *self.extra_members]

    @property
    def ensemble_size(self) -> int:
        return 1 + len(self.extra_members)

    @classmethod
    def from_members(
        cls,
        members: list[Member],
        config: SurrogateConfig,
        preset: HeadNeckPreset,
        ndof: int = 1,
        lineage: dict[str, Any] | None = None,
    ) -> SurrogateModel:
        m0 = members[0]
        return cls(
            m0.force_net,
            m0.moment_net,
            m0.input_norm,
            m0.force_norm,
            m0.moment_norm,
            config,
            preset,
            ndof,
            dict(lineage or {}),
            list(members[1:]),
        )

    def predict_members(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Every member's force and moment, each (K, n, 3): one batched forward of all members
        (:class:`_StackedEnsemble`, cached until a weight changes), on one thread; with the
        ``gated`` architecture through its output layer (:meth:`Member.predict_features`' gate)."""
        stacked = self._stacked
        if stacked is None or not stacked.valid(self):
            stacked = self._stacked = _StackedEnsemble(self)
        f, m = stacked.predict(x)
        gate = self.gate
        if gate is None:
            return f, m
        g = torch.as_tensor(gate_value(gap_from_features(x, gate.profile), gate.params)[None, :, None])
        return (
            gated_net_output_torch("force", torch.as_tensor(f), g, gate.params, axis=2).numpy(),
            gated_net_output_torch("moment", torch.as_tensor(m), g, gate.params, axis=2).numpy(),
        )

    def predict_ensemble(self, x: FloatArray) -> Prediction:
        """Ensemble mean and standard deviation (over members, ddof 0) of force and moment."""
        f, m = self.predict_members(x)
        if f.shape[0] == 1:
            return Prediction(f[0], m[0], np.zeros_like(f[0]), np.zeros_like(m[0]))
        return Prediction(f.mean(0), m.mean(0), f.std(0), m.std(0))

    def predict_features(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Force (n, 3) and moment (n, 3), the ensemble mean, for raw features x (n, 19)."""
        p = self.predict_ensemble(x)
        return p.force, p.moment


def _weights_key(model: SurrogateModel) -> tuple[tuple[int, int], ...]:
    """Identity and in-place version of every weight tensor: changes when a weight does."""
    return tuple(
        (id(p), p._version) for m in model.members for net in (m.force_net, m.moment_net) for p in net.parameters()
    )


class _StackedEnsemble:
    """All members' weights and normalisations stacked (K leading) for one batched forward per net.

    Built from a model's members on first prediction and kept on the model while its weight
    tensors are the same objects, unmodified (:func:`_weights_key`). Member k's result is that
    of :meth:`Member.predict_features` (the same standardisation and layers, as batched products).
    """

    def __init__(self, model: SurrogateModel):
        members = model.members
        self.key = _weights_key(model)
        self.dtype = model.dtype
        self.mean = np.stack([np.asarray(m.input_norm.mean, float) for m in members])[:, None, :]
        self.divisor = np.stack([np.asarray(m.input_norm.divisor, float) for m in members])[:, None, :]
        self.nets = []
        for net_name, norm_name in (("force_net", "force_norm"), ("moment_net", "moment_norm")):
            nets: list[MLP] = [getattr(m, net_name) for m in members]
            layers = [n.linears() for n in nets]
            weights = [torch.stack([ls[i].weight.detach() for ls in layers]) for i in range(len(layers[0]))]
            biases = [torch.stack([ls[i].bias.detach() for ls in layers])[:, :, None] for i in range(len(layers[0]))]
            norms = [getattr(m, norm_name) for m in members]
            scale = np.stack([np.asarray(n.scale, float) for n in norms])[:, None, :]
            mean = np.stack([np.asarray(n.mean, float) for n in norms])[:, None, :]
            self.nets.append((nets[0].activation, weights, biases, scale, mean))

    def valid(self, model: SurrogateModel) -> bool:
        return self.key == _weights_key(model)

    def predict(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Force and moment of every member, each (K, n, 3); ``PREDICT_CHUNK`` samples at a time
        (a large pool's hidden activations would not stay in the cache)."""
        z_all = torch.as_tensor((np.asarray(x, float)[None] - self.mean) / self.divisor, dtype=self.dtype)
        z_all = z_all.transpose(1, 2)  # (K, n_in, n): samples as columns
        n = z_all.shape[2]
        outs = [np.empty((z_all.shape[0], n, N_OUTPUTS)) for _ in self.nets]
        threads = torch.get_num_threads()
        torch.set_num_threads(1)  # tiny products: threads only add synchronisation (and contend on a shared machine)
        try:
            with torch.inference_mode():
                for start in range(0, n, PREDICT_CHUNK):
                    z = z_all[:, :, start : start + PREDICT_CHUNK]
                    for out, (activation, weights, biases, _, _) in zip(outs, self.nets, strict=True):
                        fn = _ACTIVATIONS[activation]()
                        h = z
                        for i, (w, b) in enumerate(zip(weights, biases, strict=True)):
                            h = torch.baddbmm(b, w, h)
                            if i < len(weights) - 1:
                                h = fn(h)
                        out[:, start : start + PREDICT_CHUNK] = h.transpose(1, 2).double().numpy()
        finally:
            torch.set_num_threads(threads)
        (force, (_, _, _, f_scale, f_mean)), (moment, (_, _, _, m_scale, m_mean)) = zip(outs, self.nets, strict=True)
        return force * f_scale + f_mean, moment * m_scale + m_mean


__all__ = ["MLP", "N_OUTPUTS", "Member", "Prediction", "Softplus", "Standardization", "SurrogateModel"]
