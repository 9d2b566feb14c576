"""Vectorised training of the K members of an ensemble, both nets, in plain PyTorch.

Every net (force, moment) of the K members is held as one leaf tensor (K, P) whose views are the
batched weights ``W_l (K, out, in)``, ``b_l (K, out)`` (:class:`BatchedNet`); one ``torch.baddbmm``
per layer evaluates all K members on their own batch, autograd gives the gradient and one
``torch.optim.Adam`` per net updates all members at once. The members' losses are disjoint sums
and Adam is elementwise, so each member's trajectory is the one it would have trained alone on the
same batches. First-layer inputs that are exactly zero in every training and validation row are
left out of the trained tensor (:class:`BatchedNet`; their gradient is exactly zero, so Adam would
never move those weights).

The two nets share the epoch's shuffle but nothing else (own loss, backward pass, Adam and early
stopping), so they train concurrently, each on its own thread with one intra-op thread
(``parallel``, default: when the process may use two CPUs). PyTorch releases the GIL inside its
kernels and runs a CPU backward pass on the calling thread; each net's arithmetic is the same on
either thread, so the weights are bit-identical with and without ``parallel``.

Batches: member k shuffles its own training rows every epoch (``torch.randperm`` with its own
generator) and cuts the permutation into ``S = ceil(n_max / batch_size)`` batches, ``n_max`` the
largest training set: batches of ``batch_size`` rows and a last, smaller one where its set is
the largest (with K = 1 exactly the paper's protocol), otherwise ``S`` nearly equal batches
(``numpy.array_split``), so that every member takes the same number of Adam steps (torch's Adam
counts steps per tensor). Rows are padded to ``batch_size`` with weight 0. The batch loss of a
member is ``sum_i w_i mean_c (net(z_i) - y_i)_c^2 / n_batch``.

Early stopping per net and member: the validation loss ``sum_i w_i mean_c err^2 / sum_i w_i``
after every epoch; the weights of a member's best epoch are kept; after ``patience`` epochs
and ``patience_steps`` Adam steps without improvement (whichever is longer: a small pool makes
few steps an epoch), or at ``max_epochs``, the member is stopped, and why is recorded
(``stop_reason``). A net with carried weights (``warm``) trains the same way from them, with
the ``warm_*`` settings where they are set: its carried weights are epoch 0, and an epoch
improves only when its loss is below ``(1 - warm_min_improvement)`` times the best. A stopped
member's result is frozen at its best epoch and it leaves
the batched tensors (its rows of the weights and of Adam's moments are dropped, the others
continue with the same state and step count, so their arithmetic is unchanged). A net stops
stepping when all its members have stopped.

The ``gated`` architecture (:class:`GatedOutputs`): the losses compare the gated output with
the target, both standardised: ``(gate_i * out(net(z_i) * scale + mean) - mean) / divisor``
with ``out`` the softplus of fx (force net) or the identity, and the sample's gate
``gate_i`` (a function of the data only: the gap of its pose) carried as a column of the
data. The ``paper`` architecture's arithmetic is unchanged (no gate column, no output layer).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial

import numpy as np
import torch
from torch import nn

from alcove.science.parallel import usable_cpus
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.gated import GateParams, gated_net_output_torch
from alcove.science.surrogate.mlp import MLP, SOFTPLUS_THRESHOLD

NETS = ("force", "moment")


@dataclass
class MemberTensors:
    """One member's standardised training and validation data (rows of features, targets, weights)."""

    z_train: torch.Tensor  # (n, 19)
    y_train: dict[str, torch.Tensor]  # net -> (n, 3)
    w_train: torch.Tensor  # (n,)
    z_val: torch.Tensor
    y_val: dict[str, torch.Tensor]
    w_val: torch.Tensor
    g_train: torch.Tensor | None = None  # (n,) the gate of each sample (gated architecture)
    g_val: torch.Tensor | None = None


@dataclass
class GatedOutputs:
    """The gated architecture's output layer in training: the gate parameters and, per net, the
    members' output standardisations (K, 3) (mean, scale, and the safe divisor)."""

    params: GateParams
    mean: dict[str, torch.Tensor]
    scale: dict[str, torch.Tensor]
    divisor: dict[str, torch.Tensor]

    def standardised(self, net: str, h: torch.Tensor, gate: torch.Tensor, members: torch.Tensor) -> torch.Tensor:
        """The gated output, standardised, of the nets' outputs ``h`` (K', 3, n) of ``members``, ``gate`` (K', 1, n)."""
        mean, scale, div = (t[net][members].unsqueeze(2) for t in (self.mean, self.scale, self.divisor))
        out = gated_net_output_torch(net, h * scale + mean, gate, self.params, axis=1)
        return (out - mean) / div


def _activation(name: str) -> Callable[[torch.Tensor], torch.Tensor]:
    if name == "softplus":
        return lambda x: nn.functional.softplus(x, beta=1.0, threshold=SOFTPLUS_THRESHOLD)
    if name == "tanh":
        return torch.tanh
    return torch.sigmoid


class BatchedNet:
    """The same MLP architecture for K members as one leaf tensor ``flat`` (K, P) with grad: row k
    holds member k's weights and biases, layer by layer; the layers' ``W_l (K, out, in)`` and
    ``b_l (K, out)`` are views of it (:meth:`layers`). One tensor per net keeps Adam's work per step
    to one fused update (its fixed cost per parameter tensor was about a tenth of a step of these small nets).

    ``columns``: the input rows the first layer is trained on (default all). Inputs that are
    exactly zero in every member's training and validation rows (the structurally constant features of planar
    motion, centred to 0) give their first-layer weights an exactly zero gradient, so Adam never
    moves them (its moments stay 0): they are left out of the trained tensor (fewer operations
    per step) and kept aside unchanged (:meth:`full_parameters`).
    """

    def __init__(self, nets: list[MLP], columns: torch.Tensor | None = None):
        self.activation = _activation(nets[0].activation)
        layers = [net.linears() for net in nets]
        weights = [torch.stack([ls[i].weight.detach() for ls in layers]) for i in range(len(layers[0]))]
        biases = [torch.stack([ls[i].bias.detach() for ls in layers]) for i in range(len(layers[0]))]
        n_in = weights[0].shape[2]
        self.columns = torch.arange(n_in) if columns is None else columns
        self.reduced = self.columns.numel() < n_in
        self.first_full = weights[0].clone()  # (K, out, n_in): the left-out columns keep these values
        if self.reduced:
            weights[0] = weights[0][:, :, self.columns]
        self.shapes = [tuple(w.shape[1:]) for w in weights]
        parts = [t.flatten(1) for pair in zip(weights, biases, strict=True) for t in pair]
        self.sizes = [p.shape[1] for p in parts]
        self.flat = torch.cat(parts, 1).requires_grad_()
        # a net of blocks (MLP.masks): the gradient of the weights between blocks is set to zero
        # before every step, so Adam never moves them from their zeros (its moments stay 0)
        masks = nets[0].masks()
        self.grad_mask: torch.Tensor | None = None
        if masks is not None:
            if self.reduced:
                masks[0] = masks[0][:, self.columns]
            ones = [torch.ones(b.shape[1], dtype=self.flat.dtype) for b in biases]
            pieces = [t.to(self.flat.dtype).flatten() for pair in zip(masks, ones, strict=True) for t in pair]
            self.grad_mask = torch.cat(pieces)

    def layers(self, flat: torch.Tensor | None = None) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """``(W_l (K, out, in), b_l (K, out))`` per layer: views of ``flat`` (default the trained tensor)."""
        pieces = (self.flat if flat is None else flat).split_with_sizes(self.sizes, 1)
        return [
            (w.view(w.shape[0], *shape), b) for w, b, shape in zip(pieces[0::2], pieces[1::2], self.shapes, strict=True)
        ]

    def parameters(self) -> list[torch.Tensor]:
        return [self.flat]

    def full_parameters(self) -> list[torch.Tensor]:
        """The parameters per layer (W_0, b_0, W_1, ..., detached) with the first layer's left-out
        input columns restored."""
        out = [p for pair in self.layers(self.flat.detach()) for p in pair]
        if self.reduced:
            out[0] = self.first_full.index_copy(2, self.columns, out[0])
        return out

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        """(K, n_in, n) -> (K, n_out, n): samples as columns (the faster layout for small widths);
        ``z`` holds the trained input rows (``columns``)."""
        layers = self.layers()
        h = z
        last = len(layers) - 1
        for i, (w, b) in enumerate(layers):
            h = torch.baddbmm(b.unsqueeze(2), w, h)
            if i < last:
                h = self.activation(h)
        return h

    def snapshot(self) -> list[torch.Tensor]:
        return [p.clone() for p in self.full_parameters()]

    def keep(self, best: list[torch.Tensor], rows: torch.Tensor, members: torch.Tensor) -> None:
        """Copy the batch rows ``rows`` into ``best`` at the members ``members`` (both index tensors)."""
        for b, p in zip(best, self.full_parameters(), strict=True):
            b[members] = p[rows]

    def select(self, rows: torch.Tensor) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """Keep only the batch rows ``rows``: a new leaf tensor; returns the (old, new) pair."""
        old = self.flat
        self.flat = old.detach()[rows].clone().requires_grad_()
        self.first_full = self.first_full[rows]
        return [(old, self.flat)]

    def write(self, best: list[torch.Tensor], nets: list[MLP]) -> None:
        with torch.no_grad():
            for k, net in enumerate(nets):
                for lin, w, b in zip(net.linears(), best[0::2], best[1::2], strict=True):
                    lin.weight.copy_(w[k])
                    lin.bias.copy_(b[k])


@dataclass(frozen=True)
class StoppingRule:
    """Step size and early stopping of one net: a new best needs a validation loss below
    ``(1 - min_improvement)`` times the best so far; a member stops after ``patience`` epochs and
    ``patience_steps`` Adam steps without one, or at ``max_epochs``."""

    learning_rate: float
    patience: int
    min_improvement: float
    max_epochs: int
    patience_steps: int = 0

    @classmethod
    def paper(cls, config: SurrogateConfig) -> StoppingRule:
        return cls(config.learning_rate, config.patience, 0.0, config.max_epochs, config.patience_steps)

    @classmethod
    def warm(cls, config: SurrogateConfig) -> StoppingRule:
        learning_rate, max_epochs, patience, min_improvement = config.warm_rule
        return cls(learning_rate, patience, min_improvement, max_epochs, config.patience_steps)

    def patience_epochs(self, steps_per_epoch: int) -> int:
        """Epochs without improvement after which a member stops: ``patience``, or more when an epoch
        is fewer than ``patience_steps / patience`` Adam steps."""
        return max(self.patience, math.ceil(self.patience_steps / max(steps_per_epoch, 1)))


#: why a member's net stopped training (``EnsembleTrainer.stop_reason``)
STOP_PATIENCE, STOP_MAX_EPOCHS = "patience", "max_epochs"


def _stack_padded(rows: list[torch.Tensor], length: int) -> torch.Tensor:
    """(K, length, ...) with each member's rows first and zeros after."""
    out = rows[0].new_zeros((len(rows), length, *rows[0].shape[1:]))
    for k, r in enumerate(rows):
        out[k, : r.shape[0]] = r
    return out


def _gate(g: torch.Tensor | None) -> torch.Tensor:
    if g is None:
        raise ValueError("gated training: every member needs the gate of its samples")
    return g[:, None]


def batch_sizes(n: int, n_batches: int, batch_size: int) -> np.ndarray:
    """How a member with ``n`` rows cuts its permutation into ``n_batches`` batches (module docstring)."""
    if n > (n_batches - 1) * batch_size:
        return np.array([batch_size] * (n_batches - 1) + [n - (n_batches - 1) * batch_size])
    return np.array([len(a) for a in np.array_split(np.arange(n), n_batches)])


class EnsembleTrainer:
    """All members of both nets: epochs of Adam steps, validation, early stopping (module docstring)."""

    def __init__(
        self,
        nets: dict[str, list[MLP]],
        data: list[MemberTensors],
        config: SurrogateConfig,
        generators: list[torch.Generator],
        gated: GatedOutputs | None = None,
        warm: dict[str, list[bool]] | None = None,
        parallel: bool | None = None,
    ):
        self.nets, self.config, self.generators, self.gated = nets, config, generators, gated
        # the two nets on two threads when this process may use two CPUs (module docstring)
        self.parallel = usable_cpus() >= 2 if parallel is None else parallel
        self.K = len(data)
        # the stopping rule and step size per net: the paper's, or the warm start's when every member
        # of the net carries its previous weights (module docstring)
        warm = warm or {}
        self.warm = {k: bool(warm.get(k)) and all(warm[k]) for k in NETS}
        self.rule = {k: StoppingRule.warm(config) if self.warm[k] else StoppingRule.paper(config) for k in NETS}
        # input rows that are not exactly zero in some member's training rows (BatchedNet)
        # (and validation rows: validation then runs on the same reduced first layer)
        nonzero = torch.stack([(d.z_train != 0).any(0) | (d.z_val != 0).any(0) for d in data]).any(0)
        self.columns = torch.nonzero(nonzero).flatten()
        self.batched = {k: BatchedNet(nets[k], self.columns) for k in NETS}
        self.optimizers = {k: self._adam(k) for k in NETS}
        self.n_rows = [d.z_train.shape[0] for d in data]
        n_max = max(self.n_rows)
        self.B = min(config.batch_size, n_max)
        self.S = math.ceil(n_max / self.B)
        # training rows per member (K, n_max + 1, C), columns: the trained features, force and
        # moment targets, (gated: the gate,) weight; padded with one zero column (weight 0) at index n_max
        table = [
            torch.cat(
                [
                    d.z_train[:, self.columns],
                    d.y_train["force"],
                    d.y_train["moment"],
                    *([] if gated is None else [_gate(d.g_train)]),
                    d.w_train[:, None],
                ],
                1,
            )
            for d in data
        ]
        self.table = _stack_padded(table, n_max + 1)
        self.pad_row = n_max
        self.n_in = self.columns.numel()
        self.sizes = [batch_sizes(n, self.S, self.B) for n in self.n_rows]
        n_val = max(d.z_val.shape[0] for d in data)
        self.z_val = _stack_padded([d.z_val[:, self.columns] for d in data], n_val).transpose(1, 2).contiguous()
        self.y_val = {k: _stack_padded([d.y_val[k] for d in data], n_val).transpose(1, 2) for k in NETS}
        self.w_val = _stack_padded([d.w_val for d in data], n_val)
        self.g_val = None if gated is None else _stack_padded([_gate(d.g_val) for d in data], n_val).transpose(1, 2)
        self.w_val_sum = torch.clamp(self.w_val.sum(1), min=torch.finfo(self.w_val.dtype).tiny)
        self.stopped = {k: torch.zeros(self.K, dtype=torch.bool) for k in NETS}
        self.active = {k: torch.arange(self.K) for k in NETS}  # the members in the batched tensors, in order
        self.best_loss = {k: torch.full((self.K,), math.inf, dtype=torch.float64) for k in NETS}
        self.best_epoch = {k: [0] * self.K for k in NETS}
        self.epochs = {k: [0] * self.K for k in NETS}
        self.patience_epochs = {k: self.rule[k].patience_epochs(self.S) for k in NETS}
        # per net and member: None while training, else STOP_PATIENCE or STOP_MAX_EPOCHS
        self.stop_reason: dict[str, list[str | None]] = {k: [None] * self.K for k in NETS}
        self.best = {k: self.batched[k].snapshot() for k in NETS}
        self.history: dict[str, list[list[float]]] = {k: [] for k in NETS}

    def _epoch_layout(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Row index (K, S*B) into the padded table, and each slot's batch size (for the loss scale)."""
        idx = np.full((self.K, self.S * self.B), self.pad_row, dtype=np.int64)
        div = np.ones((self.K, self.S * self.B))
        for k, (n, sizes) in enumerate(zip(self.n_rows, self.sizes, strict=True)):
            perm = torch.randperm(n, generator=self.generators[k]).numpy()
            starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
            chunk = np.repeat(np.arange(self.S), sizes)
            dest = chunk * self.B + (np.arange(n) - starts[chunk])
            idx[k, dest] = perm
            div[k, dest] = sizes[chunk]
        return torch.from_numpy(idx), torch.from_numpy(div)

    def _active_nets(self) -> list[str]:
        return [k for k in NETS if not bool(self.stopped[k].all())]

    def _run(self, work: Callable[[str], None], nets: list[str]) -> None:
        """``work(net)`` for each of ``nets``, concurrently when ``parallel`` (module docstring)."""
        self._concurrently([partial(work, k) for k in nets])

    def _concurrently(self, tasks: list[Callable[[], None]]) -> None:
        """Run ``tasks``, each on its own thread when ``parallel`` (one intra-op thread each)."""
        if not self.parallel or len(tasks) < 2:
            for task in tasks:
                task()
            return

        def one_thread(task: Callable[[], None]) -> None:
            torch.set_num_threads(1)  # the intra-op setting is per thread (OpenMP): the caller's one thread
            task()

        with ThreadPoolExecutor(max_workers=len(tasks), thread_name_prefix="alcove-train") as pool:
            for done in [pool.submit(one_thread, task) for task in tasks]:
                done.result()

    def epoch(self) -> None:
        """One epoch: the members' shuffle (shared by both nets), then per net and batch one loss,
        one backward pass and one Adam step; the two nets concurrently (``parallel``)."""
        idx, div = self._epoch_layout()
        # each member's rows in its epoch's order, one member at a time (a member's table stays in the cache;
        # whole rows, not column by column: 3 times faster than a gather of the (K, C, n) table in float64)
        shuffled = self.table.new_empty((self.K, idx.shape[1], self.table.shape[2]))

        def gather(members: range) -> None:
            for k in members:
                torch.index_select(self.table[k], 0, idx[k], out=shuffled[k])

        halves = [range((self.K + 1) // 2), range((self.K + 1) // 2, self.K)]
        self._concurrently([partial(gather, members) for members in halves if members])
        cols = shuffled.transpose(1, 2)  # (K, C, S*B): samples as columns (a view)
        z = cols[:, : self.n_in]
        y = {"force": cols[:, self.n_in : self.n_in + 3], "moment": cols[:, self.n_in + 3 : self.n_in + 6]}
        scale = (cols[:, -1] / div.to(cols.dtype) / 3.0).unsqueeze(1)
        gate = None if self.gated is None else cols[:, self.n_in + 6 : self.n_in + 7]

        def steps(k: str) -> None:
            rows = self.active[k]
            full = rows.numel() == self.K
            net = self.batched[k]
            zk, yk, wk = (z, y[k], scale) if full else (z[rows], y[k][rows], scale[rows])
            gk = None if gate is None else (gate if full else gate[rows])
            optimizer = self.optimizers[k]
            for s in range(self.S):
                sl = slice(s * self.B, (s + 1) * self.B)
                optimizer.zero_grad(set_to_none=True)
                err = self._output(k, net.forward(zk[:, :, sl]), gk, sl) - yk[:, :, sl]
                torch.autograd.backward((err.square() * wk[:, :, sl]).sum())
                if net.grad_mask is not None:
                    assert net.flat.grad is not None
                    net.flat.grad.mul_(net.grad_mask)
                optimizer.step()

        self._run(steps, self._active_nets())

    def _output(self, k: str, out: torch.Tensor, gate: torch.Tensor | None, sl: slice) -> torch.Tensor:
        """The nets' standardised outputs as trained: the paper's as they are, the ``gated``
        architecture's through its output layer (``gate``: the active members' gate columns)."""
        if self.gated is None:
            return out
        assert gate is not None
        return self.gated.standardised(k, out, gate[:, :, sl], self.active[k])

    def _adam(self, k: str) -> torch.optim.Adam:
        return torch.optim.Adam(self.batched[k].parameters(), lr=self.rule[k].learning_rate, fused=True)

    def _drop_members(self, k: str, rows: torch.Tensor) -> None:
        """Keep only the batch rows ``rows`` of net ``k``: a new Adam carrying their moments and step."""
        old_state = self.optimizers[k].state
        pairs = self.batched[k].select(rows)
        adam = self._adam(k)
        for old, new in pairs:
            state = old_state.get(old)
            if state:
                adam.state[new] = {
                    "step": state["step"].clone(),
                    "exp_avg": state["exp_avg"][rows].clone(),
                    "exp_avg_sq": state["exp_avg_sq"][rows].clone(),
                }
        self.optimizers[k] = adam

    def validate(self, epoch: int) -> bool:
        """Validation losses, best weights, stopping; False when every member of every net has stopped.

        ``epoch`` 0 (before any step) makes the starting weights a candidate: a warm start keeps the
        previous model's weights of a member when no epoch improves on them within ``patience``."""
        self._run(lambda k: self._validate_net(k, epoch), self._active_nets())
        return bool(self._active_nets())

    def _validate_net(self, k: str, epoch: int) -> None:
        with torch.no_grad():
            members = self.active[k]
            net = self.batched[k]
            out = net.forward(self.z_val[members])
            if self.gated is not None:
                assert self.g_val is not None
                out = self.gated.standardised(k, out, self.g_val[members], members)
            err = (out - self.y_val[k][members]).square()
            loss = (err.mean(1) * self.w_val[members]).sum(1) / self.w_val_sum[members]
            full = torch.full((self.K,), math.nan, dtype=torch.float64)
            full[members] = loss.double()
            self.history[k].append(full.tolist())
            improved = loss.double() < self.best_loss[k][members] * (1.0 - self.rule[k].min_improvement)
            if bool(improved.any()):
                rows = torch.nonzero(improved).flatten()
                self.best_loss[k][members[rows]] = loss[rows].double()
                net.keep(self.best[k], rows, members[rows])
        keep = []
        for row, m in enumerate(members.tolist()):
            self.epochs[k][m] = epoch
            if improved[row]:
                self.best_epoch[k][m] = epoch
            if epoch - self.best_epoch[k][m] >= self.patience_epochs[k]:
                self.stopped[k][m], self.stop_reason[k][m] = True, STOP_PATIENCE
                continue
            if epoch >= self.rule[k].max_epochs:
                self.stopped[k][m], self.stop_reason[k][m] = True, STOP_MAX_EPOCHS
                continue
            keep.append(row)
        if keep and len(keep) < members.numel():  # some stopped: they leave the batched tensor
            rows = torch.tensor(keep)
            self._drop_members(k, rows)
            self.active[k] = members[rows]

    def still_improving(self, k: str, m: int) -> bool:
        """Whether member ``m``'s net ``k`` stopped at ``max_epochs`` while it was still improving (its
        best epoch within the last ``patience`` epochs: more epochs would likely have helped)."""
        return (
            self.stop_reason[k][m] == STOP_MAX_EPOCHS
            and self.epochs[k][m] - self.best_epoch[k][m] < (self.patience_epochs[k])
        )

    def finish(self) -> None:
        """Write every member's best weights into its nets."""
        for k in NETS:
            self.batched[k].write(self.best[k], self.nets[k])


__all__ = [
    "NETS",
    "STOP_MAX_EPOCHS",
    "STOP_PATIENCE",
    "BatchedNet",
    "EnsembleTrainer",
    "GatedOutputs",
    "MemberTensors",
    "StoppingRule",
    "batch_sizes",
]
