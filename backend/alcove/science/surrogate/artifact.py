"""Self-contained model artifact: a folder that loads without any database.

``surrogate.json``
    format and version, feature names, number of degrees of freedom, the geometry preset,
    the training configuration, both networks (architecture and float64 weights; JSON
    floats round-trip exactly), the input and output standardisation, and lineage fields
    (seed, datasets, test sets, metrics, plus whatever the caller adds: campaign,
    iteration, pool version, parent model version, ...).
    Format 2: ``networks`` and ``normalization`` are ensemble member 0; ``members`` lists
    members 1 .. K-1 with their own ``networks`` and ``normalization`` (format 1, one model,
    is still read, as an ensemble of 1). A net of blocks (``normal_force: "own"``,
    :class:`.mlp.MLP`) also lists its ``blocks`` (output indices) and ``block_inputs``; its
    layers are ordinary dense layers whose weights between blocks are zero (checked on loading).
    A ``config`` without ``normal_force`` holds a shared net (read as ``"shared"``).
    ``architecture``: ``paper`` or ``gated`` (the config's), and for ``gated`` the ``gate``
    parameters and the head profile the gap is measured from (:mod:`.gated`; informative: the
    gate is rebuilt from the config and the preset on loading, and a mismatch is an error).
``force.pt``, ``moment.pt``
    TorchScript modules mapping raw features (n, 19) to force / moment (n, 3) in the
    headrest frame, normalisation included, for use outside alcove
    (``torch.jit.load("force.pt")(x)``); the ensemble mean for K > 1.
``*.casadi``, ``*.onnx``
    The portable exports (:mod:`.portable`, docs/exports.md), written by :func:`save_artifact`
    with ``exports=True``.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np
import torch
from torch import nn

import alcove
from alcove.science.errors import FieldError
from alcove.science.geometry import HeadNeckPreset
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.gated import R_X, T_00, T_20, Gate
from alcove.science.surrogate.mlp import MLP, Member, Standardization, SurrogateModel

FORMAT = "alcove-surrogate"
FORMAT_VERSION = 2
READABLE_VERSIONS = (1, 2)
JSON_NAME = "surrogate.json"


class ArtifactError(FieldError):
    """A model artifact cannot be read; ``field`` names what is wrong."""


class _Scripted(nn.Module):
    """Raw features -> physical output, normalisation included (scriptable)."""

    if TYPE_CHECKING:  # buffers, registered in __init__ (TorchScript cannot read these string annotations)
        x_mean: torch.Tensor
        x_scale: torch.Tensor
        y_mean: torch.Tensor
        y_scale: torch.Tensor

    def __init__(
        self,
        net: MLP,
        input_norm: Standardization,
        output_norm: Standardization,
        gate: Gate | None = None,
        is_force: bool = False,
    ):
        super().__init__()
        self.linears = nn.ModuleList([_copy_linear(lin) for lin in net.linears()])
        self.activation = net.activation
        # the gated architecture's output layer (alcove.science.surrogate.gated, written out for TorchScript)
        self.gated = gate is not None
        self.is_force = is_force
        gp, pr = (gate.params, gate.profile) if gate is not None else (None, None)
        self.open_gap = gp.open_gap if gp is not None else 0.0
        self.blend = gp.blend if gp is not None else 1.0
        self.force_width = gp.force_width if gp is not None else 1.0
        self.profile = [pr.cx, pr.cz, pr.ax, pr.az] if pr is not None else [0.0, 0.0, 1.0, 1.0]
        self.register_buffer("x_mean", torch.as_tensor(input_norm.mean, dtype=torch.float64))
        self.register_buffer("x_scale", torch.as_tensor(input_norm.divisor, dtype=torch.float64))
        self.register_buffer("y_mean", torch.as_tensor(output_norm.mean, dtype=torch.float64))
        self.register_buffer("y_scale", torch.as_tensor(output_norm.scale, dtype=torch.float64))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = (x.to(torch.float64) - self.x_mean) / self.x_scale
        n = len(self.linears)
        for i, lin in enumerate(self.linears):
            h = lin(h)
            if i < n - 1:
                if self.activation == "softplus":
                    h = torch.nn.functional.softplus(h, beta=1.0, threshold=40.0)
                elif self.activation == "tanh":
                    h = torch.tanh(h)
                else:
                    h = torch.sigmoid(h)
        out = h * self.y_scale + self.y_mean
        if not self.gated:
            return out
        x = x.to(torch.float64)
        c, s = x[:, 6], x[:, 8]
        cx, cz, ax, az = self.profile[0], self.profile[1], self.profile[2], self.profile[3]
        gap = x[:, 0] + c * cx - s * cz - torch.sqrt((ax * c) ** 2 + (az * s) ** 2)
        t = torch.clamp((self.open_gap - gap) / self.blend, 0.0, 1.0)
        gate = (t**3 * (10 - 15 * t + 6 * t**2)).unsqueeze(1)
        if self.is_force:
            z = out[:, 0:1] / self.force_width
            fx = self.force_width * (torch.clamp(z, min=0.0) + torch.log1p(torch.exp(-z.abs())))
            out = torch.cat([fx, out[:, 1:]], 1)
        return gate * out


class _ScriptedMean(nn.Module):
    """The mean of the members' scripted nets (an ensemble's TorchScript export)."""

    def __init__(self, members: list[_Scripted]):
        super().__init__()
        self.members = nn.ModuleList(members)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        outs = [m(x) for m in self.members]
        return torch.stack(outs).mean(0)


def _copy_linear(lin: nn.Linear) -> nn.Linear:
    out = nn.Linear(lin.in_features, lin.out_features, dtype=torch.float64)
    with torch.no_grad():
        out.weight.copy_(lin.weight)
        out.bias.copy_(lin.bias)
    return out


def _net_to_dict(net: MLP) -> dict[str, Any]:
    return {
        "hidden": list(net.hidden),
        "activation": net.activation,
        **({"blocks": [list(b) for b in net.blocks]} if net.blocks else {}),
        **({"block_inputs": [None if i is None else list(i) for i in net.block_inputs]} if net.block_inputs else {}),
        "layers": [
            {"weight": lin.weight.detach().double().tolist(), "bias": lin.bias.detach().double().tolist()}
            for lin in net.linears()
        ],
    }


def _net_from_dict(d: dict[str, Any], dtype: torch.dtype, field: str, n_in: int) -> MLP:
    try:
        net = MLP(
            d["hidden"],
            d["activation"],
            n_in=n_in,
            dtype=dtype,
            blocks=d.get("blocks", ()),
            block_inputs=d.get("block_inputs", ()),
        )
        linears = net.linears()
        if len(linears) != len(d["layers"]):
            raise ArtifactError(
                f"{field}.layers", f"has {len(d['layers'])} layers, the architecture needs {len(linears)}"
            )
        with torch.no_grad():
            for i, (lin, layer) in enumerate(zip(linears, d["layers"], strict=False)):
                w = torch.as_tensor(np.asarray(layer["weight"], float), dtype=dtype)
                b = torch.as_tensor(np.asarray(layer["bias"], float), dtype=dtype)
                if w.shape != lin.weight.shape or b.shape != lin.bias.shape:
                    raise ArtifactError(
                        f"{field}.layers.{i}",
                        f"weight {tuple(w.shape)} / bias {tuple(b.shape)} do not fit {tuple(lin.weight.shape)}",
                    )
                lin.weight.copy_(w)
                lin.bias.copy_(b)
            for i, (lin, mask) in enumerate(zip(linears, net.masks() or [], strict=False)):
                if bool((lin.weight[mask == 0] != 0).any()):
                    raise ArtifactError(f"{field}.layers.{i}", f"weights between the blocks {net.blocks} must be zero")
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, ArtifactError):
            raise
        raise ArtifactError(field, f"malformed network: {exc}") from None
    return net


def _member_dict(m: Member) -> dict[str, Any]:
    return {
        "networks": {"force": _net_to_dict(m.force_net), "moment": _net_to_dict(m.moment_net)},
        "normalization": {
            "input": m.input_norm.to_dict(),
            "force": m.force_norm.to_dict(),
            "moment": m.moment_norm.to_dict(),
        },
    }


def _member_from_dict(d: dict[str, Any], dtype: torch.dtype, field: str, n_in: int) -> Member:
    norm = d["normalization"]
    input_norm = Standardization.from_dict(norm["input"])
    if input_norm.mean.shape != (n_in,):
        raise ArtifactError(f"{field}normalization.input", f"has {input_norm.mean.size} entries, the inputs are {n_in}")
    return Member(
        force_net=_net_from_dict(d["networks"]["force"], dtype, f"{field}networks.force", n_in),
        moment_net=_net_from_dict(d["networks"]["moment"], dtype, f"{field}networks.moment", n_in),
        input_norm=input_norm,
        force_norm=Standardization.from_dict(norm["force"]),
        moment_norm=Standardization.from_dict(norm["moment"]),
    )


def _architecture_dict(model: SurrogateModel) -> dict[str, Any]:
    gate = model.gate
    if gate is None:
        return {"name": model.config.architecture}
    return {
        "name": model.config.architecture,
        "gate": asdict(gate.params),
        "gap": "r_x + T_00 cx - T_20 cz - sqrt((ax T_00)^2 + (az T_20)^2), (cx, cz, ax, az) = preset.profile",
        "feature_indices": {"r_x": R_X, "T_00": T_00, "T_20": T_20},
    }


def artifact_dict(model: SurrogateModel, lineage: dict[str, Any] | None = None) -> dict[str, Any]:
    """The JSON document of a model (see the module docstring)."""
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "feature_names": list(model.config.input_names),
        "outputs": {"force": ["fx", "fy", "fz"], "moment": ["mx", "my", "mz"]},
        "frame": "headrest; moment about the head frame origin; SI units",
        "ndof": model.ndof,
        "preset": model.preset.to_dict(),
        "config": model.config.model_dump(mode="json"),
        "architecture": _architecture_dict(model),
        **_member_dict(model.members[0]),
        "members": [_member_dict(m) for m in model.members[1:]],
        "lineage": {**model.lineage, **(lineage or {})},
        "software": {"alcove": alcove.__version__, "torch": torch.__version__},
        "torchscript": {"force": "force.pt", "moment": "moment.pt"},
    }


def model_from_dict(doc: dict[str, Any]) -> SurrogateModel:
    if doc.get("format") != FORMAT:
        raise ArtifactError("format", f"expected {FORMAT!r}, got {doc.get('format')!r}")
    if doc.get("format_version") not in READABLE_VERSIONS:
        raise ArtifactError(
            "format_version",
            f"unsupported version {doc.get('format_version')!r} (this alcove reads 1 and {FORMAT_VERSION})",
        )
    try:
        raw = doc["config"]
        if isinstance(raw, dict) and "normal_force" not in raw:
            raw = {**raw, "normal_force": "shared"}  # a config without the key holds a shared net
        config = SurrogateConfig.parse(raw)
        if list(doc.get("feature_names", [])) != list(config.input_names):
            raise ArtifactError(
                "feature_names",
                f"do not match the {len(config.input_names)} inputs of the feature set {config.features!r} "
                "of this alcove version",
            )
        extra = doc.get("members", [])
        if not isinstance(extra, list):
            raise ArtifactError("members", "must be a list")
        if "ensemble_size" not in raw or config.ensemble_size != 1 + len(extra):
            if "ensemble_size" in raw:
                raise ArtifactError(
                    "members", f"holds {1 + len(extra)} member(s), the config says ensemble_size {config.ensemble_size}"
                )
            config = config.model_copy(update={"ensemble_size": 1 + len(extra)})  # format 1: one model
        # held in float64 whatever the training's precision (config.dtype): float32 weights are exact in float64
        n_in = len(config.input_names)
        members = [_member_from_dict(doc, torch.float64, "", n_in)]
        members += [_member_from_dict(m, torch.float64, f"members.{i}.", n_in) for i, m in enumerate(extra)]
        model = SurrogateModel.from_members(
            members,
            config=config,
            preset=HeadNeckPreset.from_dict(doc["preset"]),
            ndof=int(doc["ndof"]),
            lineage=dict(doc.get("lineage", {})),
        )
        recorded = doc.get("architecture")  # absent before the gated architecture: the paper's
        if recorded is not None and recorded != _architecture_dict(model):
            raise ArtifactError(
                "architecture",
                f"{recorded!r} does not match the config's architecture {config.architecture!r} "
                "with this alcove's gate",
            )
        return model
    except KeyError as exc:
        raise ArtifactError(str(exc.args[0]), "missing entry") from None


def save_artifact(
    model: SurrogateModel, path: str | Path, lineage: dict[str, Any] | None = None, *, exports: bool = False
) -> Path:
    """Write ``surrogate.json``, ``force.pt`` and ``moment.pt`` into the folder ``path``; with
    ``exports`` also the CasADi and ONNX files of :func:`.portable.write_exports`."""
    root = Path(path)
    root.mkdir(parents=True, exist_ok=True)
    doc = artifact_dict(model, lineage)
    (root / JSON_NAME).write_text(json.dumps(doc, indent=1))
    with warnings.catch_warnings():
        warnings.simplefilter(
            "ignore", DeprecationWarning
        )  # torch.jit.script is deprecated but TorchScript is the contract
        for key in ("force", "moment"):
            scripted = [
                _Scripted(getattr(m, f"{key}_net"), m.input_norm, getattr(m, f"{key}_norm"), model.gate, key == "force")
                for m in model.members
            ]
            module: nn.Module = scripted[0] if len(scripted) == 1 else _ScriptedMean(scripted)
            torch.jit.save(torch.jit.script(module), str(root / doc["torchscript"][key]))
    if exports:
        from alcove.science.surrogate.portable import write_exports

        write_exports(model, root)
    return root


def casadi_contact_from_artifact(path: str | Path, preset: HeadNeckPreset) -> ca.Function:
    """Load a model artifact (directory or its ``surrogate.json``) and export it as the OCP's
    contact function (:func:`.export.casadi_contact_function`)."""
    from alcove.science.surrogate.casadi_contact import casadi_contact_function

    return casadi_contact_function(load_artifact(path), preset)


def load_artifact(path: str | Path) -> SurrogateModel:
    """Read a model from its folder (or the ``surrogate.json`` inside it)."""
    p = Path(path)
    json_path = p / JSON_NAME if p.is_dir() else p
    if not json_path.exists():
        raise ArtifactError("model", f"{json_path} does not exist")
    try:
        doc = json.loads(json_path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ArtifactError(JSON_NAME, f"not valid JSON: {exc}") from None
    if not isinstance(doc, dict):
        raise ArtifactError(JSON_NAME, "must be a JSON object")
    return model_from_dict(doc)


__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "ArtifactError",
    "artifact_dict",
    "casadi_contact_from_artifact",
    "load_artifact",
    "model_from_dict",
    "save_artifact",
]
