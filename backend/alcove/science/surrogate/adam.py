"""Adam on one flat parameter tensor (:class:`FlatAdam`), without importing ``torch.optim``."""

from __future__ import annotations

import math

import torch


class FlatAdam:
    """Adam (Kingma & Ba; the update of ``torch.optim.Adam`` with its defaults) on one flat tensor.

    ``torch.optim`` imports ``torch._dynamo`` on first use, 2-7 s per process on this
    machine, which a one-shot CLI call or a fresh worker pays on every training. The update is
    ATen's fused Adam kernel (``torch._fused_adam_``, what ``torch.optim.Adam(fused=True)``
    calls: one operation instead of seven, which matters at ~5,000 steps of a few hundred
    parameters), or the same update in five tensor operations where that kernel is missing.
    ``tests/science/surrogate`` checks both against ``torch.optim.Adam``.
    """

    def __init__(
        self,
        param: torch.Tensor,
        lr: float,
        betas: tuple[float, float] = (0.9, 0.999),
        eps: float = 1e-8,
        grad: torch.Tensor | None = None,
        fused: bool = True,
    ):
        self.param, self.lr, self.betas, self.eps = param, lr, betas, eps
        self.grad = grad  # where the gradient is stored (default: param.grad)
        self.exp_avg = torch.zeros_like(param)
        self.exp_avg_sq = torch.zeros_like(param)
        self.steps = 0
        self.fused = fused and hasattr(torch, "_fused_adam_")
        self._step_count = torch.zeros((), dtype=param.dtype)  # the fused kernel reads the step from a tensor

    @torch.no_grad()
    def step(self) -> None:
        grad = self.param.grad if self.grad is None else self.grad
        assert grad is not None
        b1, b2 = self.betas
        self.steps += 1
        if self.fused:
            self._step_count.fill_(self.steps)
            torch._fused_adam_(
                [self.param],
                [grad],
                [self.exp_avg],
                [self.exp_avg_sq],
                [],
                [self._step_count],
                lr=self.lr,
                beta1=b1,
                beta2=b2,
                weight_decay=0.0,
                eps=self.eps,
                amsgrad=False,
                maximize=False,
            )
            return
        self.exp_avg.lerp_(grad, 1 - b1)
        self.exp_avg_sq.mul_(b2).addcmul_(grad, grad, value=1 - b2)
        bias1, bias2 = 1 - b1**self.steps, 1 - b2**self.steps
        denom = (self.exp_avg_sq.sqrt() / math.sqrt(bias2)).add_(self.eps)
        self.param.addcdiv_(self.exp_avg, denom, value=-self.lr / bias1)


__all__ = ["FlatAdam"]
