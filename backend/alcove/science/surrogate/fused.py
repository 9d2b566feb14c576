"""The force and moment MLPs fused into one network for training, with hand-written backpropagation.

For nets this small (19-6-6-4-3 and 19-6-6-6-4-3) a training step costs the per-operation
overhead of PyTorch, not arithmetic. :class:`FusedNets` therefore steps both nets in one
pass: layer ``i`` of every net that has one becomes a single matrix product with a
block-structured weight (the first layer's blocks side by side, since both nets read the
same features; later layers block-diagonal; a net whose output layer this is puts its
outputs in the first columns, the hidden units of the deeper net follow), so a step issues
about half the operations of two separate nets. The fused weights are stored pre-transposed,
``(in, out)``, as views into one flat parameter tensor, so that Adam updates one tensor per step (:class:`FlatAdam` in
:mod:`.adam`). Entries outside the blocks start at 0 and their gradient is masked to 0, so
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

from alcove.science.surrogate.mlp import MLP, SOFTPLUS_THRESHOLD


@dataclass
class _Block:
    """Net ``net``'s layer in a fused weight: rows ``rows`` (inputs), columns ``cols`` (outputs)."""

    net: int
    rows: slice
    cols: slice


@dataclass
class _Layer:
    """``A = H_in @ weight + bias``; columns ``[outputs of the nets ending here | hidden units]``."""

    weight: torch.Tensor  # (in, out) view into the flat parameters
    bias: torch.Tensor
    weight_grad: torch.Tensor
    bias_grad: torch.Tensor
    weight_t: torch.Tensor  # weight.t(), prebuilt
    blocks: list[_Block]
    outputs: list[tuple[int, slice]]  # (net, columns) of the nets whose output layer this is
    n_outputs: int  # hidden units start at this column
    activations: list[tuple[slice, str]]  # column segments of the hidden part (relative to it) and their activation


class FusedNets:
    """Several MLPs sharing their input, trained as one block-structured network."""

    def __init__(self, nets: list[MLP]):
        n_in = {net.linears()[0].in_features for net in nets}
        if len(n_in) != 1:
            raise ValueError(f"nets: fused training needs one input width, got {sorted(n_in)}")
        self.nets = nets
        self.dtype = nets[0].linears()[0].weight.dtype
        linears = [net.linears() for net in nets]
        width_in = n_in.pop()
        in_rows = {k: slice(0, width_in) for k in range(len(nets))}  # where each net reads the layer input
        plan: list[tuple[int, int, list[_Block], list[tuple[int, slice]], int, list[tuple[slice, str]]]] = []
        for i in range(max(len(ls) for ls in linears)):
            present = [k for k in range(len(nets)) if len(linears[k]) > i]  # = the nets in the layer input
            ending = [k for k in present if len(linears[k]) == i + 1]
            continuing = [k for k in present if k not in ending]
            blocks: list[_Block] = []
            outputs: list[tuple[int, slice]] = []
            acts: list[tuple[slice, str]] = []
            col = 0
            for k in ending + continuing:
                cols = slice(col, col + linears[k][i].out_features)
                blocks.append(_Block(k, in_rows[k], cols))
                col = cols.stop
                if k in ending:
                    outputs.append((k, cols))
            n_outputs = sum(c.stop - c.start for _, c in outputs)
            in_rows = {}  # the hidden units of this layer are the next layer's input
            for blk in blocks[len(ending) :]:
                rel = slice(blk.cols.start - n_outputs, blk.cols.stop - n_outputs)
                in_rows[blk.net] = rel
                activation = nets[blk.net].activation
                if acts and acts[-1][1] == activation:
                    acts[-1] = (slice(acts[-1][0].start, rel.stop), activation)
                else:
                    acts.append((rel, activation))
            plan.append((max(r.stop for r in (b.rows for b in blocks)), col, blocks, outputs, n_outputs, acts))
        n_params = sum(a * b + b for a, b, *_ in plan)
        self.parameter = torch.zeros(n_params, dtype=self.dtype)
        self.grad = torch.zeros(n_params, dtype=self.dtype)
        self.mask = torch.zeros(n_params, dtype=self.dtype)
        self.layers: list[_Layer] = []
        offset = 0
        for a, b, blocks, outputs, n_outputs, acts in plan:

            def view(t: torch.Tensor, start: int, shape: tuple[int, ...]) -> torch.Tensor:
                return t[start : start + math.prod(shape)].view(shape)

            w = view(self.parameter, offset, (a, b))
            self.layers.append(
                _Layer(
                    w,
                    view(self.parameter, offset + a * b, (b,)),
                    view(self.grad, offset, (a, b)),
                    view(self.grad, offset + a * b, (b,)),
                    w.t(),
                    blocks,
                    outputs,
                    n_outputs,
                    acts,
                )
            )
            offset += a * b + b
        self.active = [True] * len(nets)
        self.load()

    # -- parameters -------------------------------------------------------------------------

    def _block_views(self, flat: torch.Tensor, k: int) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """(weight (out, in), bias) of net ``k``'s layers as views into ``flat`` (parameter-shaped)."""
        out: list[tuple[torch.Tensor, torch.Tensor]] = []
        offset = 0
        for layer in self.layers:
            a, b = layer.weight.shape
            for blk in layer.blocks:
                if blk.net == k:
                    out.append(
                        (
                            flat[offset : offset + a * b].view(a, b)[blk.rows, blk.cols].t(),
                            flat[offset + a * b : offset + a * b + b][blk.cols],
                        )
                    )
            offset += a * b + b
        return out

    def load(self) -> None:
        """Copy the nets' current weights into the fused parameters (and set the gradient mask)."""
        self.parameter.zero_()
        self.mask.zero_()
        for k, net in enumerate(self.nets):
            for (w, b), (mw, mb), lin in zip(
                self._block_views(self.parameter, k), self._block_views(self.mask, k), net.linears(), strict=False
            ):
                w.copy_(lin.weight.detach())
                b.copy_(lin.bias.detach())
                if self.active[k]:
                    mw.fill_(1.0)
                    mb.fill_(1.0)

    def store(self, k: int, flat: torch.Tensor | None = None) -> None:
        """Write net ``k``'s weights from ``flat`` (default: the current parameters) into the net."""
        src = self.parameter if flat is None else flat
        with torch.no_grad():
            for (w, b), lin in zip(self._block_views(src, k), self.nets[k].linears(), strict=False):
                lin.weight.copy_(w)
                lin.bias.copy_(b)

    def weights(self, k: int) -> list[torch.Tensor]:
        """A copy of net ``k``'s current weights and biases, in ``net.parameters()`` order."""
        return [t.clone() for wb in self._block_views(self.parameter, k) for t in wb]

    def transfer(self, src: torch.Tensor, other: FusedNets, dst: torch.Tensor) -> None:
        """Copy the blocks of every net of ``other`` from ``src`` (laid out as this network's
        parameters) to ``dst`` (laid out as ``other``'s): parameters or Adam moments."""
        for j, net in enumerate(other.nets):
            i = next(i for i, mine in enumerate(self.nets) if mine is net)
            for (ws, bs), (wd, bd) in zip(self._block_views(src, i), other._block_views(dst, j), strict=False):
                wd.copy_(ws)
                bd.copy_(bs)

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
            a = torch.mm(h, layer.weight).add_(layer.bias)
            for k, cols in layer.outputs:
                outputs[k] = a[:, cols]
            if layer.activations:
                pre = a[:, layer.n_outputs :].contiguous() if layer.n_outputs else a
                h = _cat(
                    [
                        (_softplus_value_fast if fast and act == "softplus" else _ACTIVATION[act])(pre[:, cols])
                        for cols, act in layer.activations
                    ]
                )
        return outputs

    def set_loss_gradient(
        self, z: torch.Tensor, targets: list[torch.Tensor], w: torch.Tensor, fast: bool = True
    ) -> None:
        """Store in :attr:`grad` the gradient of every active net's batch loss
        ``sum_i w_i mean_c (net(z_i) - y_i)_c^2 / n`` (inactive nets: 0)."""
        self._gradient(z, targets, w, fast)
        if fast and not math.isfinite(float(self.grad.sum())):
            self._gradient(z, targets, w, False)  # exp overflowed (a > 709) or the step diverged: exact functions

    def _gradient(self, z: torch.Tensor, targets: list[torch.Tensor], w: torch.Tensor, fast: bool) -> None:
        n = z.shape[0]
        inputs: list[torch.Tensor] = []  # input of each layer
        slopes: list[torch.Tensor | None] = []  # activation derivative of each layer's hidden units
        residuals: list[list[torch.Tensor]] = []  # dLoss/dOutput of the nets ending at each layer
        scale: dict[int, torch.Tensor] = {}
        h = z
        for layer in self.layers:
            inputs.append(h)
            a = torch.mm(h, layer.weight).add_(layer.bias)
            res = []
            for k, cols in layer.outputs:
                y = targets[k]
                n_out = y.shape[1]
                if n_out not in scale:
                    scale[n_out] = (w * (2.0 / (n_out * n)))[:, None]
                res.append(
                    (a.sub_(y) if len(layer.outputs) == 1 and not layer.activations else torch.sub(a[:, cols], y)).mul_(
                        scale[n_out]
                    )
                )
            residuals.append(res)
            if layer.activations:
                pre = a[:, layer.n_outputs :].contiguous() if layer.n_outputs else a
                pairs = [
                    (_softplus_fast if fast and act == "softplus" else _WITH_SLOPE[act])(
                        pre if len(layer.activations) == 1 else pre[:, cols]
                    )
                    for cols, act in layer.activations
                ]
                h = _cat([p[0] for p in pairs])
                slopes.append(_cat([p[1] for p in pairs]))
            else:
                slopes.append(None)
        d_h: torch.Tensor | None = None  # dLoss/d(hidden units) of the layer being processed
        for i in range(len(self.layers) - 1, -1, -1):
            layer = self.layers[i]
            slope = slopes[i]
            if slope is None:
                grad_a = _cat(residuals[i])
            else:
                assert d_h is not None
                grad_a = _cat([*residuals[i], d_h.mul_(slope)])
            torch.mm(inputs[i].t(), grad_a, out=layer.weight_grad)
            torch.sum(grad_a, 0, out=layer.bias_grad)
            if i > 0:
                d_h = torch.mm(grad_a, layer.weight_t)
        self.grad.mul_(self.mask)


def _cat(parts: list[torch.Tensor]) -> torch.Tensor:
    return parts[0] if len(parts) == 1 else torch.cat(parts, 1)


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
