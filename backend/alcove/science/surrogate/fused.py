"""The force and moment MLPs fused into one network for training, with hand-written backpropagation.

For nets this small (19-6-6-4-3 and 19-6-6-6-4-3) a training step costs the per-operation
overhead of PyTorch, not arithmetic. :class:`FusedNets` therefore steps both nets in one
pass: layer ``i`` of every net that has one becomes a single matrix product with a
block-structured weight (the first layer's blocks side by side, since both nets read the
same features; later layers block-diagonal), so a step issues about half the operations of
two separate nets. The fused weights are stored pre-transposed, ``(in, out)``, as views into
one flat parameter tensor, so that Adam updates one tensor per step (:class:`FlatAdam` in
:mod:`.training`). Entries outside the blocks start at 0 and their gradient is masked to 0, so
Adam never moves them (its update is ``lr * m / (sqrt(v) + eps)`` with ``m = v = 0``): the
fused network computes exactly the two nets, and training it is training the two nets side by
side on the same batches (their parameters and losses are disjoint).

Softplus: ``torch.nn.functional.softplus`` and ``torch.sigmoid`` (its derivative) cost two
scalar ``log1p(exp)``/``exp`` passes; the step instead computes ``e = exp(a)`` once
(vectorised), ``softplus = log(1 + e)`` and ``sigmoid = e / (1 + e)``. This is softplus to
rounding (absolute error < 2.3e-16 against ``log1p``; ``log(1 + e) = a`` to rounding above
the threshold 40 where ``Softplus`` switches to ``a``) as long as ``exp`` does not overflow
(a > 709): a step whose gradient is not finite is recomputed with the exact functions.
``tests/science/surrogate/test_surrogate_training.py`` checks the gradient against autograd.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from alcove.science.surrogate.mlp import SOFTPLUS_THRESHOLD, MLP


@dataclass
class _Block:
    """Net ``net``'s layer ``layer`` inside a fused weight: rows ``rows`` (inputs), columns ``cols``."""

    net: int
    layer: int
    rows: slice
    cols: slice


@dataclass
class _Group:
    """One fused matrix product ``A = H_in[:, rows] @ W + b``.

    ``hidden``: the hidden layer ``i`` of every net continuing past it (activation applied,
    output feeds layer ``i + 1``); otherwise the output layer of net ``blocks[0].net``."""

    hidden: bool
    rows: slice  # columns of the layer input this product reads
    weight: torch.Tensor  # (in, out) view into the flat parameters
    bias: torch.Tensor
    weight_grad: torch.Tensor
    bias_grad: torch.Tensor
    weight_t: torch.Tensor  # weight.t(), prebuilt
    blocks: list[_Block]
    activations: list[tuple[slice, str]]  # hidden only: column segments and their activation
    whole_input: bool = False  # rows are all the columns of the layer input (no slicing needed)


class FusedNets:
    """Several MLPs sharing their input, trained as one block-structured network."""

    def __init__(self, nets: list[MLP]):
        n_in = {net.linears()[0].in_features for net in nets}
        if len(n_in) != 1:
            raise ValueError(f"nets: fused training needs one input width, got {sorted(n_in)}")
        self.nets = nets
        self.dtype = nets[0].linears()[0].weight.dtype
        linears = [net.linears() for net in nets]
        depth = max(len(ls) for ls in linears)
        # plan: per layer, the hidden group of continuing nets and the output group of each ending net;
        # the hidden output of layer i holds the continuing nets side by side in net order
        shapes: list[tuple[int, int]] = []  # (in, out) of each fused weight, in flat order
        plan: list[tuple[bool, slice, list[_Block], list[tuple[slice, str]]]] = []
        self.layers: list[list[int]] = []  # layer -> indices into plan
        input_width: list[int] = []  # width of each layer's input
        width_in = n_in.pop()
        in_cols = {k: slice(0, width_in) for k in range(len(nets))}  # where each net reads its input
        for i in range(depth):
            input_width.append(max(c.stop for c in in_cols.values()))
            present = [k for k in range(len(nets)) if len(linears[k]) > i]
            continuing = [k for k in present if len(linears[k]) > i + 1]
            layer = []
            for k in present:
                if k not in continuing:
                    lin = linears[k][i]
                    rows = in_cols[k]
                    plan.append((False, rows, [_Block(k, i, slice(0, lin.in_features), slice(0, lin.out_features))], []))
                    shapes.append((lin.in_features, lin.out_features))
                    layer.append(len(plan) - 1)
            if continuing:
                lo, hi = min(in_cols[k].start for k in continuing), max(in_cols[k].stop for k in continuing)
                blocks, acts, col, next_cols = [], [], 0, {}
                for k in continuing:
                    lin = linears[k][i]
                    cols = slice(col, col + lin.out_features)
                    blocks.append(_Block(k, i, slice(in_cols[k].start - lo, in_cols[k].stop - lo), cols))
                    activation = nets[k].activation
                    if acts and acts[-1][1] == activation:
                        acts[-1] = (slice(acts[-1][0].start, cols.stop), activation)
                    else:
                        acts.append((cols, activation))
                    next_cols[k] = cols
                    col = cols.stop
                plan.append((True, slice(lo, hi), blocks, acts))
                shapes.append((hi - lo, col))
                layer.append(len(plan) - 1)
                in_cols = next_cols
            self.layers.append(layer)
        n_params = sum(a * b + b for a, b in shapes)
        self.parameter = torch.zeros(n_params, dtype=self.dtype)
        self.grad = torch.zeros(n_params, dtype=self.dtype)
        self.mask = torch.zeros(n_params, dtype=self.dtype)
        self.groups: list[_Group] = []
        offset = 0
        layer_of = {gi: i for i, layer in enumerate(self.layers) for gi in layer}
        for gi, ((hidden, rows, blocks, acts), (a, b)) in enumerate(zip(plan, shapes)):
            def view(t: torch.Tensor, start: int, shape: tuple[int, ...]) -> torch.Tensor:
                return t[start : start + math.prod(shape)].view(shape)

            w, bias = view(self.parameter, offset, (a, b)), view(self.parameter, offset + a * b, (b,))
            self.groups.append(_Group(hidden, rows, w, bias, view(self.grad, offset, (a, b)), view(self.grad, offset + a * b, (b,)),
                                      w.t(), blocks, acts, rows.start == 0 and rows.stop == input_width[layer_of[gi]]))
            offset += a * b + b
        self.active = [True] * len(nets)
        self.load()

    # -- parameters -------------------------------------------------------------------------

    def _block_views(self, flat: torch.Tensor, k: int) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """(weight (out, in), bias) of net ``k``'s layers as views into ``flat`` (parameter-shaped)."""
        out: list[tuple[torch.Tensor, torch.Tensor]] = []
        offset = 0
        for g in self.groups:
            a, b = g.weight.shape
            for blk in g.blocks:
                if blk.net == k:
                    w = flat[offset : offset + a * b].view(a, b)[blk.rows, blk.cols].t()
                    out.append((w, flat[offset + a * b : offset + a * b + b][blk.cols]))
            offset += a * b + b
        return out

    def load(self) -> None:
        """Copy the nets' current weights into the fused parameters (and set the gradient mask)."""
        self.parameter.zero_()
        self.mask.zero_()
        for k, net in enumerate(self.nets):
            for (w, b), (mw, mb), lin in zip(self._block_views(self.parameter, k), self._block_views(self.mask, k), net.linears()):
                w.copy_(lin.weight.detach())
                b.copy_(lin.bias.detach())
                if self.active[k]:
                    mw.fill_(1.0)
                    mb.fill_(1.0)

    def store(self, k: int, flat: torch.Tensor | None = None) -> None:
        """Write net ``k``'s weights from ``flat`` (default: the current parameters) into the net."""
        src = self.parameter if flat is None else flat
        with torch.no_grad():
            for (w, b), lin in zip(self._block_views(src, k), self.nets[k].linears()):
                lin.weight.copy_(w)
                lin.bias.copy_(b)

    def freeze(self, k: int) -> None:
        """Net ``k`` stops training: its gradient is 0 from now on."""
        self.active[k] = False
        for w, b in self._block_views(self.mask, k):
            w.zero_()
            b.zero_()

    # -- forward / backward ------------------------------------------------------------------

    def forward(self, z: torch.Tensor) -> list[torch.Tensor]:
        """Outputs (n, n_out) of every net for standardised inputs ``z`` (no gradient)."""
        outputs = self._forward(z, fast=True)
        if not all(math.isfinite(float(out.sum())) for out in outputs):
            outputs = self._forward(z, fast=False)  # exp overflowed: exact functions
        return outputs

    def _forward(self, z: torch.Tensor, fast: bool) -> list[torch.Tensor]:
        outputs: list[torch.Tensor] = [torch.empty(0)] * len(self.nets)
        h = z
        for layer in self.layers:
            h_next = h
            for gi in layer:
                g = self.groups[gi]
                a = torch.mm(h if g.whole_input else h[:, g.rows], g.weight).add_(g.bias)
                if g.hidden:
                    h_next = _cat([(_softplus_value_fast if fast and act == "softplus" else _ACTIVATION[act])(a[:, cols])
                                   for cols, act in g.activations])
                else:
                    outputs[g.blocks[0].net] = a
            h = h_next
        return outputs

    def set_loss_gradient(self, z: torch.Tensor, targets: list[torch.Tensor], w: torch.Tensor, fast: bool = True) -> None:
        """Store in :attr:`grad` the gradient of every active net's batch loss
        ``sum_i w_i mean_c (net(z_i) - y_i)_c^2 / n`` (inactive nets: 0)."""
        self._gradient(z, targets, w, fast)
        if fast and not math.isfinite(float(self.grad.sum())):
            self._gradient(z, targets, w, False)  # exp overflowed (a > 709) or the step diverged: exact functions

    def _gradient(self, z: torch.Tensor, targets: list[torch.Tensor], w: torch.Tensor, fast: bool) -> None:
        n = z.shape[0]
        inputs: list[torch.Tensor] = []  # input of each layer
        slopes: list[torch.Tensor] = []  # activation derivative of each hidden output
        residual: dict[int, torch.Tensor] = {}  # output group -> dLoss/dOutput
        scale: dict[int, torch.Tensor] = {}
        h = z
        for layer in self.layers:
            inputs.append(h)
            h_next = h
            for gi in layer:
                g = self.groups[gi]
                a = torch.mm(h if g.whole_input else h[:, g.rows], g.weight).add_(g.bias)
                if g.hidden:
                    pairs = [(_softplus_fast if fast and act == "softplus" else _WITH_SLOPE[act])(a if len(g.activations) == 1 else a[:, cols])
                             for cols, act in g.activations]
                    h_next, slope = _cat([p[0] for p in pairs]), _cat([p[1] for p in pairs])
                    slopes.append(slope)
                else:
                    y = targets[g.blocks[0].net]
                    n_out = y.shape[1]
                    if n_out not in scale:
                        scale[n_out] = (w * (2.0 / (n_out * n)))[:, None]
                    residual[gi] = a.sub_(y).mul_(scale[n_out])
            h = h_next
        d_h: torch.Tensor | None = None  # dLoss/d(hidden output) of the layer being processed
        for i in range(len(self.layers) - 1, -1, -1):
            pieces: list[tuple[int, torch.Tensor]] = []  # (first input column, dLoss/dInput part)
            for gi in self.layers[i]:
                g = self.groups[gi]
                if g.hidden:
                    assert d_h is not None
                    grad_a = d_h.mul_(slopes[i])
                else:
                    grad_a = residual[gi]
                x = inputs[i] if g.whole_input else inputs[i][:, g.rows]
                torch.mm(x.t(), grad_a, out=g.weight_grad)
                torch.sum(grad_a, 0, out=g.bias_grad)
                if i > 0:
                    pieces.append((g.rows.start, torch.mm(grad_a, g.weight_t)))
            if i > 0:
                d_h = _assemble(pieces, inputs[i].shape[1], n, self.dtype)
        self.grad.mul_(self.mask)


def _cat(parts: list[torch.Tensor]) -> torch.Tensor:
    return parts[0] if len(parts) == 1 else torch.cat(parts, 1)


def _assemble(pieces: list[tuple[int, torch.Tensor]], width: int, n: int, dtype: torch.dtype) -> torch.Tensor:
    """The (n, width) sum of column pieces; a concatenation when they tile the columns."""
    pieces.sort(key=lambda p: p[0])
    col = 0
    for start, t in pieces:
        if start != col:
            break
        col += t.shape[1]
    else:
        if col == width:
            return _cat([t for _, t in pieces])
    total = torch.zeros(n, width, dtype=dtype)
    for start, t in pieces:
        total[:, start : start + t.shape[1]].add_(t)
    return total


def _softplus_fast(a: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    e = torch.exp(a)
    d = torch.add(e, 1.0)
    slope = e.div_(d)  # e^a / (1 + e^a), before d is overwritten
    return d.log_(), slope  # log(1 + e^a)


def _softplus_value_fast(a: torch.Tensor) -> torch.Tensor:
    return torch.exp(a).add_(1.0).log_()


def _softplus(a: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    return nn.functional.softplus(a, beta=1.0, threshold=SOFTPLUS_THRESHOLD), torch.sigmoid(a)


def _tanh(a: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    h = torch.tanh(a)
    return h, torch.mul(h, h).neg_().add_(1.0)


def _sigmoid(a: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    h = torch.sigmoid(a)
    return h, torch.sub(h, h * h)


_WITH_SLOPE = {"softplus": _softplus, "tanh": _tanh, "sigmoid": _sigmoid}  # activation and its derivative
_ACTIVATION = {
    "softplus": lambda a: nn.functional.softplus(a, beta=1.0, threshold=SOFTPLUS_THRESHOLD),
    "tanh": torch.tanh,
    "sigmoid": torch.sigmoid,
}

__all__ = ["FusedNets"]
