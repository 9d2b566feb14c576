"""The epoch engines of surrogate training: the compiled C kernel, or PyTorch.

Both train the force and moment nets side by side on the same shuffled batches (their
parameters and losses are disjoint, so this equals training them one after the other) and
implement :class:`EpochTrainer`, the interface the early-stopping loop of :mod:`.training`
drives. :func:`make_trainer` picks one (``ALCOVE_TRAINING_KERNEL``, see :mod:`.kernel`).
"""

from __future__ import annotations

import logging
from typing import ClassVar, Protocol

import torch

from alcove.science.arrays import FloatArray
from alcove.science.surrogate.adam import FlatAdam
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.fused import FusedNets
from alcove.science.surrogate.kernel import (
    KernelChoiceError,
    KernelNets,
    KernelUnavailable,
    kernel_supports,
    requested_kernel,
)
from alcove.science.surrogate.mlp import MLP

_log = logging.getLogger(__name__)
NETS = ("force", "moment")


class EpochTrainer(Protocol):
    """One training engine for the nets in :data:`NETS`; it keeps each net's best weights itself."""

    name: ClassVar[str]

    def epoch(self, order: torch.Tensor) -> None:
        """One pass over the training rows in ``order``, in batches of the configured size."""

    def validation_outputs(self, z_val: torch.Tensor) -> list[tuple[str, torch.Tensor]]:
        """(net, standardised outputs) of every net still training."""

    def remember_best(self, k: str) -> None:
        """Keep a copy of net ``k``'s current weights as its best."""

    def stop(self, stopped: list[str]) -> bool:
        """Freeze the nets ``stopped``; False when no net is left training."""

    def restore_best(self, k: str) -> None:
        """Write the weights last kept by :meth:`remember_best` back into net ``k``."""


class TorchTrainer:
    """Both nets fused into one PyTorch network (:class:`.fused.FusedNets`), :class:`FlatAdam`."""

    name: ClassVar[str] = "torch"

    def __init__(
        self,
        nets: dict[str, MLP],
        z: torch.Tensor,
        y: dict[str, torch.Tensor],
        w: torch.Tensor,
        config: SurrogateConfig,
    ):
        self.nets, self.config = nets, config
        self.active = list(NETS)  # the nets still training, in the fused network's order
        self.fused = FusedNets([nets[k] for k in self.active])
        self.optimizer = FlatAdam(self.fused.parameter, lr=config.learning_rate, grad=self.fused.grad)
        self.n_in = z.shape[1]
        # features, both targets and the weights side by side: one gather per epoch
        self.table = torch.cat([z, y["force"], y["moment"], w[:, None]], dim=1)
        self.columns = {"force": slice(self.n_in, self.n_in + 3), "moment": slice(self.n_in + 3, self.n_in + 6)}
        self.best: dict[str, list[torch.Tensor]] = {}

    def epoch(self, order: torch.Tensor) -> None:
        # shuffled once per epoch: batches are contiguous slices, not one scattered gather each
        shuffled = self.table.index_select(0, order)
        targets = [self.columns[k] for k in self.active]
        bs, n_in = self.config.batch_size, self.n_in
        for start in range(0, shuffled.shape[0], bs):
            batch = shuffled[start : start + bs]
            self.fused.set_loss_gradient(batch[:, :n_in], [batch[:, c] for c in targets], batch[:, -1])
            self.optimizer.step()

    def validation_outputs(self, z_val: torch.Tensor) -> list[tuple[str, torch.Tensor]]:
        return list(zip(self.active, self.fused.forward(z_val), strict=False))

    def snapshot(self, k: str) -> list[torch.Tensor]:
        if k in self.active:
            return self.fused.weights(self.active.index(k))
        return [p.detach().clone() for p in self.nets[k].parameters()]

    def stop(self, stopped: list[str]) -> bool:
        """Freeze ``stopped``; False when no net is left. The nets still training continue alone
        (same updates, fewer operations per step)."""
        self.active = [k for k in self.active if k not in stopped]
        if not self.active:
            return False
        self.fused, self.optimizer = _without_stopped(self.fused, self.optimizer, [self.nets[k] for k in self.active])
        return True

    def remember_best(self, k: str) -> None:
        self.best[k] = self.snapshot(k)

    def restore_best(self, k: str) -> None:
        with torch.no_grad():
            for p, best_p in zip(self.nets[k].parameters(), self.best[k], strict=True):
                p.copy_(best_p)


class KernelTrainer:
    """Both nets trained by the compiled kernel (:mod:`.kernel`): one C call per epoch."""

    name: ClassVar[str] = "c"

    def __init__(
        self,
        nets: dict[str, MLP],
        z: torch.Tensor,
        y: dict[str, torch.Tensor],
        w: torch.Tensor,
        config: SurrogateConfig,
    ):
        self.config = config
        n_in = z.shape[1]
        self.table = torch.cat([z, y["force"], y["moment"], w[:, None]], dim=1).numpy()
        self.w_col = self.table.shape[1] - 1
        self.kernel = KernelNets([nets[k] for k in NETS], y_cols=[n_in, n_in + 3])
        self.index = {k: i for i, k in enumerate(NETS)}
        self.best: dict[str, FloatArray] = {}

    def epoch(self, order: torch.Tensor) -> None:
        self.kernel.train_epoch(
            self.table, self.w_col, order.numpy(), self.config.batch_size, self.config.learning_rate
        )

    def validation_outputs(self, z_val: torch.Tensor) -> list[tuple[str, torch.Tensor]]:
        x = z_val.numpy()
        return [
            (k, torch.from_numpy(self.kernel.forward(i, x))) for k, i in self.index.items() if self.kernel.active(i)
        ]

    def snapshot(self, k: str) -> FloatArray:
        return self.kernel.weights(self.index[k])

    def stop(self, stopped: list[str]) -> bool:
        for k in stopped:
            self.kernel.freeze(self.index[k])
        return any(self.kernel.active(i) for i in self.index.values())

    def remember_best(self, k: str) -> None:
        self.best[k] = self.snapshot(k)

    def restore_best(self, k: str) -> None:
        self.kernel.store(self.index[k], self.best[k])


def make_trainer(
    nets: dict[str, MLP], z: torch.Tensor, y: dict[str, torch.Tensor], w: torch.Tensor, config: SurrogateConfig
) -> TorchTrainer | KernelTrainer:
    """The C kernel where it is requested (``ALCOVE_TRAINING_KERNEL``) or, by default, available; else PyTorch."""
    choice = requested_kernel()
    if choice != "torch":
        reason = kernel_supports(list(nets.values()))
        if reason is None:
            try:
                return KernelTrainer(nets, z, y, w, config)
            except KernelUnavailable as exc:
                reason = str(exc)
        if choice == "c":
            raise KernelChoiceError(f"is c but the C training kernel cannot be used: {reason}")
        _log.info("training with PyTorch: the C kernel cannot be used (%s)", reason)
    return TorchTrainer(nets, z, y, w, config)


def _without_stopped(fused: FusedNets, optimizer: FlatAdam, remaining: list[MLP]) -> tuple[FusedNets, FlatAdam]:
    """A fused network of the ``remaining`` nets carrying over their weights and Adam state."""
    smaller = FusedNets(remaining)
    fused.transfer(fused.parameter, smaller, smaller.parameter)
    adam = FlatAdam(
        smaller.parameter,
        lr=optimizer.lr,
        betas=optimizer.betas,
        eps=optimizer.eps,
        grad=smaller.grad,
        fused=optimizer.fused,
    )
    fused.transfer(optimizer.exp_avg, smaller, adam.exp_avg)
    fused.transfer(optimizer.exp_avg_sq, smaller, adam.exp_avg_sq)
    adam.steps = optimizer.steps
    return smaller, adam


__all__ = ["NETS", "EpochTrainer", "KernelTrainer", "TorchTrainer", "make_trainer"]
