"""The compiled training kernel: gradients against autograd, Adam against torch.optim.Adam,
the forward pass against the nets, the choice of implementation, build failures and the cache."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import torch

from alcove.science.surrogate import kernel as kernel_module
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.kernel import KernelChoiceError, KernelNets, KernelUnavailable, load_kernel
from alcove.science.surrogate.mlp import MLP
from alcove.science.surrogate.training import train_surrogate

ARCHITECTURES = [
    [((6, 6, 4), "softplus"), ((6, 6, 6, 4), "softplus")],  # the paper's pair
    [((5, 4, 3), "tanh"), ((8,), "sigmoid")],  # other activations, force deeper
    [((40, 17), "softplus"), ((3,), "tanh")],  # wider than a SIMD vector, one hidden layer
]


def _nets(architectures, seed=0):
    g = torch.Generator().manual_seed(seed)
    nets = [MLP(hidden, act) for hidden, act in architectures]
    for net in nets:
        net.reset_parameters(g)
    return nets, g


def _table(n, g, scale=1.0):
    """Features (19), force targets (3), moment targets (3), positive weights (1)."""
    t = torch.randn(n, 26, dtype=torch.float64, generator=g)
    t[:, :19] *= scale
    t[:, 25] = torch.rand(n, dtype=torch.float64, generator=g) + 0.1
    return t


def _autograd(nets, table, rows):
    x, w = table[rows, :19], table[rows, 25]
    grads = []
    for net, col in zip(nets, (19, 22), strict=False):
        loss = ((net(x) - table[rows, col : col + 3]) ** 2).mean(1) @ w / len(rows)
        grads.append(torch.cat([g.flatten() for g in torch.autograd.grad(loss, list(net.parameters()))]).numpy())
    return grads


@pytest.mark.parametrize("architectures", ARCHITECTURES)
@pytest.mark.parametrize("n", [64, 300])  # one partial chunk; chunks of 128 + a remainder
def test_kernel_gradient_equals_autograd(architectures, n):
    nets, g = _nets(architectures)
    table = _table(n + 50, g)
    rows = torch.randperm(n + 50, generator=g)[:n]  # a scattered subset, as a shuffled batch
    kn = KernelNets(nets, y_cols=[19, 22])
    kn.gradient(table.numpy(), 25, rows.numpy())
    for got, expected in zip(kn.grads, _autograd(nets, table, rows), strict=False):
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)
        assert np.abs(got).max() > 1e-3  # not a vacuous comparison
    # a frozen net's gradient is left alone, the other is recomputed the same
    kn.grads[0][:] = 7.0
    kn.freeze(0)
    kn.gradient(table.numpy(), 25, rows.numpy())
    assert np.all(kn.grads[0] == 7.0)
    np.testing.assert_allclose(kn.grads[1], _autograd(nets, table, rows)[1], rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("architectures", ARCHITECTURES)
def test_kernel_forward_equals_the_nets(architectures):
    nets, g = _nets(architectures, seed=1)
    x = torch.randn(333, 19, dtype=torch.float64, generator=g)
    kn = KernelNets(nets, y_cols=[19, 22])
    for k, net in enumerate(nets):
        np.testing.assert_allclose(kn.forward(k, x.numpy()), net(x).detach().numpy(), rtol=1e-13, atol=1e-14)


def test_kernel_softplus_beyond_the_exp_range_is_exact():
    nets, g = _nets(ARCHITECTURES[0], seed=2)
    table = _table(200, g, scale=3000.0)  # pre-activations far beyond exp's range (709)
    rows = torch.arange(200)
    assert max(float(net.linears()[0](table[:, :19]).detach().abs().max()) for net in nets) > 1000
    kn = KernelNets(nets, y_cols=[19, 22])
    kn.gradient(table.numpy(), 25, rows.numpy())
    for got, expected in zip(kn.grads, _autograd(nets, table, rows), strict=False):
        assert np.all(np.isfinite(got))
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-9)


def test_kernel_epoch_is_minibatch_adam_of_torch():
    """An epoch = consecutive batches of the given order, torch.optim.Adam after each."""
    nets, g = _nets(ARCHITECTURES[0], seed=3)
    reference = [MLP(net.hidden, net.activation) for net in nets]
    for ref, net in zip(reference, nets, strict=False):
        ref.load_state_dict(net.state_dict())
    n, batch = 700, 256  # 3 batches, the last one short
    table = _table(n, g)
    kn = KernelNets(nets, y_cols=[19, 22])
    optimizers = [torch.optim.Adam(ref.parameters(), lr=0.01) for ref in reference]
    for _ in range(4):
        order = torch.randperm(n, generator=g)
        kn.train_epoch(table.numpy(), 25, order.numpy(), batch, 0.01)
        for start in range(0, n, batch):
            rows = order[start : start + batch]
            for ref, opt, grad in zip(reference, optimizers, _autograd(reference, table, rows), strict=False):
                opt.zero_grad()
                offset = 0
                for p in ref.parameters():
                    p.grad = torch.from_numpy(grad[offset : offset + p.numel()].copy()).view_as(p)
                    offset += p.numel()
                opt.step()
    assert kn.steps == [4 * 3, 4 * 3]
    for k, ref in enumerate(reference):
        expected = torch.cat([p.detach().flatten() for p in ref.parameters()]).numpy()
        start = torch.cat([p.detach().flatten() for p in nets[k].parameters()]).numpy()
        assert np.abs(expected - start).max() > 0.01  # the weights did move
        np.testing.assert_allclose(kn.params[k], expected, rtol=1e-10, atol=1e-12)
        kn.store(k)
        np.testing.assert_array_equal(
            torch.cat([p.detach().flatten() for p in nets[k].parameters()]).numpy(), kn.params[k]
        )


def test_kernel_rejects_bad_arguments():
    nets, g = _nets(ARCHITECTURES[0])
    kn = KernelNets(nets, y_cols=[19, 22])
    table = _table(10, g).numpy()
    with pytest.raises(IndexError, match=r"^rows: indices must lie in \[0, 10\)"):
        kn.gradient(table, 25, np.array([0, 10]))
    with pytest.raises(ValueError, match=r"^table: needs a C-contiguous float64 matrix"):
        kn.gradient(table.astype(np.float32), 25, np.arange(10))
    with pytest.raises(ValueError, match=r"^table: 20 columns are too few"):
        kn.gradient(np.ascontiguousarray(table[:, :20]), 19, np.arange(10))
    with pytest.raises(KernelUnavailable, match="dtype float32"):
        KernelNets([MLP((4,), dtype=torch.float32)], y_cols=[19])


@pytest.mark.parametrize("choice", ["c", "torch"])
def test_both_implementations_learn_the_smooth_law(monkeypatch, smooth_pool, choice):
    monkeypatch.setenv("ALCOVE_TRAINING_KERNEL", choice)
    result = train_surrogate(smooth_pool, SurrogateConfig(max_epochs=60, batch_size=128), seed=0)
    assert result.model.lineage["training_kernel"] == choice
    force_scale = float(np.std(np.concatenate([ds.force for ds in smooth_pool])))
    assert result.metrics.rmse["force"]["test"] < 0.1 * force_scale


def test_a_bad_kernel_choice_names_the_variable(monkeypatch, smooth_pool):
    monkeypatch.setenv("ALCOVE_TRAINING_KERNEL", "fortran")
    with pytest.raises(ValueError, match=r"^ALCOVE_TRAINING_KERNEL: 'fortran' is not one of auto, c, torch"):
        train_surrogate(smooth_pool, SurrogateConfig(max_epochs=1), seed=0)
    monkeypatch.setenv("ALCOVE_TRAINING_KERNEL", "c")
    with pytest.raises(
        KernelChoiceError, match=r"^ALCOVE_TRAINING_KERNEL: is c but the C training kernel cannot be used: .*float32"
    ):
        train_surrogate(smooth_pool, SurrogateConfig(max_epochs=1, dtype="float32"), seed=0)
    monkeypatch.setenv("ALCOVE_TRAINING_KERNEL", "auto")  # float32: PyTorch trains it
    assert (
        train_surrogate(smooth_pool, SurrogateConfig(max_epochs=1, dtype="float32"), seed=0).model.lineage[
            "training_kernel"
        ]
        == "torch"
    )


@pytest.fixture
def broken_compiler(tmp_path, monkeypatch):
    """A real 'compiler' process that fails with a message, and an empty kernel cache."""
    cc = tmp_path / "cc"
    cc.write_text("#!/bin/sh\necho 'fatal error: the test compiler refuses' >&2\nexit 1\n")
    cc.chmod(0o755)
    monkeypatch.setenv("CC", str(cc))
    monkeypatch.setenv("ALCOVE_KERNEL_CACHE", str(tmp_path / "cache"))
    kernel_module._load.cache_clear()
    yield cc
    kernel_module._load.cache_clear()  # later tests load the real kernel again


def test_a_failing_build_gives_the_compiler_message_and_auto_falls_back(broken_compiler, monkeypatch, smooth_pool):
    with pytest.raises(KernelUnavailable, match=r"did not build: .*the test compiler refuses"):
        load_kernel()
    monkeypatch.setenv("ALCOVE_TRAINING_KERNEL", "auto")
    result = train_surrogate(smooth_pool, SurrogateConfig(max_epochs=2), seed=0)
    assert result.model.lineage["training_kernel"] == "torch"
    monkeypatch.setenv("ALCOVE_TRAINING_KERNEL", "c")
    with pytest.raises(KernelChoiceError, match="the test compiler refuses"):
        train_surrogate(smooth_pool, SurrogateConfig(max_epochs=2), seed=0)
    assert not list((broken_compiler.parent / "cache").glob("*.so"))


_BUILD_AND_TRAIN = textwrap.dedent("""
    import sys
    sys.path.insert(0, sys.argv[1])
    from conftest import make_smooth_pool
    from test_surrogate_training import _weights_digest
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.science.surrogate.training import train_surrogate
    model = train_surrogate(make_smooth_pool(6), SurrogateConfig(max_epochs=3, batch_size=64), seed=5).model
    assert model.lineage["training_kernel"] == "c", model.lineage
    print(_weights_digest(model))
""")


def test_processes_building_into_an_empty_cache_at_once_agree(tmp_path):
    env = {**os.environ, "ALCOVE_KERNEL_CACHE": str(tmp_path), "ALCOVE_TRAINING_KERNEL": "c"}
    here = str(Path(__file__).parent)
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _BUILD_AND_TRAIN, here],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for _ in range(3)
    ]
    outputs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [err for _, err in outputs]
    assert len({out.strip() for out, _ in outputs}) == 1  # bit-identical weights
    assert len(list(tmp_path.glob("*.so"))) == 1 and not list(tmp_path.glob("*.tmp"))
