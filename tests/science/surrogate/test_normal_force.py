"""The normal force with hidden layers of its own (``normal_force: "own"``).

The FE friction depends on the path (two motions holding the same angle give opposite fz), the
normal force on the state. In one shared force net the contradictory fz targets pull the hidden
layers that fx needs; with blocks, fx is an MLP of its own. Checked here: a net of blocks is
exactly the union of separate MLPs, training keeps the weights between blocks at zero, the
exports and artifacts carry it, and on a pool whose tangential force contradicts itself the
normal force is learned as if the tangential force were not there.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch
from conftest import make_smooth_pool

from alcove.science.geometry import DEFAULT_PRESET as P
from alcove.science.surrogate.artifact import ArtifactError, artifact_dict, model_from_dict
from alcove.science.surrogate.casadi_contact import casadi_contact_function
from alcove.science.surrogate.config import SurrogateConfig, SurrogateConfigError
from alcove.science.surrogate.mlp import MLP
from alcove.science.surrogate.training import predict, predict_ensemble, train_surrogate


def test_a_net_of_blocks_is_the_union_of_separate_mlps() -> None:
    net = MLP((5, 4), "softplus", n_in=7, n_out=3, blocks=((0,), (1, 2)), block_inputs=((0, 1, 2), None))
    net.reset_parameters(torch.Generator().manual_seed(3))
    lin = net.linears()
    assert [tuple(lin_.weight.shape) for lin_ in lin] == [(10, 7), (8, 10), (3, 8)]
    # block 0: inputs 0-2 -> units 0-4 -> units 0-3 -> output 0; block 1: every input -> 5-9 -> 4-7 -> outputs 1, 2
    normal = MLP((5, 4), "softplus", n_in=3, n_out=1)
    tangential = MLP((5, 4), "softplus", n_in=7, n_out=2)
    with torch.no_grad():
        pieces = [
            (normal, [(slice(0, 5), slice(0, 3)), (slice(0, 4), slice(0, 5)), ([0], slice(0, 4))]),
            (tangential, [(slice(5, 10), slice(None)), (slice(4, 8), slice(5, 10)), ([1, 2], slice(4, 8))]),
        ]
        for small, cuts in pieces:
            for target, source, (rows, cols) in zip(small.linears(), lin, cuts, strict=True):
                target.weight.copy_(source.weight[rows][:, cols])
                target.bias.copy_(source.bias[rows])
    x = torch.randn(50, 7, dtype=torch.float64, generator=torch.Generator().manual_seed(4))
    out = net(x)
    torch.testing.assert_close(out[:, :1], normal(x[:, :3]), rtol=0, atol=1e-14)
    torch.testing.assert_close(out[:, 1:], tangential(x), rtol=0, atol=1e-14)
    # each block starts as the MLP it stands for: weights within U(-1/sqrt(fan_in), 1/sqrt(fan_in))
    assert float(lin[0].weight.detach()[:5, :3].abs().max()) <= 1 / np.sqrt(3)
    assert float(lin[1].weight.detach()[:4, :5].abs().max()) <= 1 / np.sqrt(5)


@pytest.fixture(scope="module")
def conflicting_pool():
    """The smooth law's fx with a tangential force whose sign each simulation draws (a path the
    state does not show): no function of (q, qd) fits fz, fx is a function of the state."""
    rng = np.random.default_rng(1)
    out = []
    for ds in make_smooth_pool(20, 100, seed=0):
        f = ds.force.copy()
        f[:, 2] = rng.choice([-1.0, 1.0]) * 20.0 * (1 + 0.5 * np.sin(3 * ds.q[:, 0]))
        out.append(dataclasses.replace(ds, force=f))
    return out


def fx_rmse(model, pool) -> float:
    err = [predict_ensemble(model, ds.q, ds.qd).force[:, 0] - ds.force[:, 0] for ds in pool]
    return float(np.sqrt(np.mean(np.concatenate(err) ** 2)))


def test_a_contradictory_tangential_force_does_not_pull_the_normal_force(conflicting_pool) -> None:
    held_out = make_smooth_pool(8, 100, seed=7)
    config = {"ensemble_size": 2, "max_epochs": 400}
    shared = train_surrogate(conflicting_pool, SurrogateConfig(**config, normal_force="shared"), seed=0).model
    own = train_surrogate(conflicting_pool, SurrogateConfig(**config, normal_force="own"), seed=0).model
    e_shared, e_own = fx_rmse(shared, held_out), fx_rmse(own, held_out)
    # fx of the smooth law spans about 80 N; measured: shared 0.9-1.1 N, own 0.06-0.15 N (two seeds)
    assert e_own < 0.4 * e_shared, (e_own, e_shared)
    # the weights between the blocks stayed exactly zero through training, for every member
    for member in own.members:
        for lin, mask in zip(member.force_net.linears(), member.force_net.masks() or [], strict=True):
            assert torch.all(lin.weight[mask == 0] == 0)
        assert member.moment_net.masks() is None  # the moment net is the paper's


def test_exports_and_artifacts_carry_the_blocks(conflicting_pool) -> None:
    config = SurrogateConfig(ensemble_size=1, max_epochs=20, normal_force="own")
    model = train_surrogate(conflicting_pool, config, seed=0).model
    again = model_from_dict(artifact_dict(model))
    assert again.force_net.blocks == ((0,), (1, 2)) and again.force_net.same_architecture(model.force_net)
    q = np.linspace(P.theta_min, P.theta_max, 30)
    qd = np.linspace(-2, 2, 30)
    ref = predict(model, np.arange(q.size, dtype=float), q, qd)
    got = predict(again, np.arange(q.size, dtype=float), q, qd)
    np.testing.assert_array_equal(got.force, ref.force)
    # CasADi's rebuild of the net (the OCP's contact function) is the same function
    fn = casadi_contact_function(model, P)
    wrench = np.array(fn.map(q.size)(q[None], qd[None])).T
    np.testing.assert_allclose(wrench[:, :3], ref.force, rtol=1e-10, atol=1e-10)
    # an artifact whose weights between blocks are not zero is not the model it claims to be
    doc = artifact_dict(model)
    doc["networks"]["force"]["layers"][1]["weight"][0][-1] = 0.5  # member 0: block 0's unit from block 1's
    with pytest.raises(ArtifactError, match="between the blocks"):
        model_from_dict(doc)


def test_an_artifact_whose_config_does_not_name_the_normal_force_holds_a_shared_net(conflicting_pool) -> None:
    """The default is "own"; an artifact config without the key (written before the option) is a
    net without blocks, and reads back as "shared" with its predictions unchanged."""
    assert SurrogateConfig().normal_force == "own"
    config = SurrogateConfig(ensemble_size=1, max_epochs=5, normal_force="shared")
    model = train_surrogate(conflicting_pool, config, seed=0).model
    doc = artifact_dict(model)
    del doc["config"]["normal_force"]
    again = model_from_dict(doc)
    assert again.config.normal_force == "shared" and again.force_net.blocks == ()
    q, qd = np.linspace(P.theta_min, P.theta_max, 10), np.zeros(10)
    np.testing.assert_array_equal(
        predict(again, np.arange(10, dtype=float), q, qd).force, predict(model, np.arange(10, dtype=float), q, qd).force
    )


def test_with_the_history_features_the_normal_force_reads_the_state_only(conflicting_pool) -> None:
    config = SurrogateConfig(ensemble_size=1, max_epochs=20, normal_force="own", features="history")
    assert config.block_inputs("force") == (tuple(range(19)), None) and config.block_inputs("moment") == ()
    net = MLP.from_config(
        config.force,
        n_in=len(config.input_names),
        blocks=config.output_blocks("force"),
        block_inputs=config.block_inputs("force"),
    )
    net.reset_parameters(torch.Generator().manual_seed(0))
    x = torch.randn(20, len(config.input_names), dtype=torch.float64, generator=torch.Generator().manual_seed(1))
    moved = x.clone()
    moved[:, 19:] += 5.0  # other history states, the same state
    assert torch.equal(net(x)[:, 0], net(moved)[:, 0])
    assert not torch.allclose(net(x)[:, 2], net(moved)[:, 2])


def test_the_setting_is_validated_and_a_warm_start_across_it_starts_afresh(conflicting_pool) -> None:
    with pytest.raises(SurrogateConfigError) as err:
        SurrogateConfig.parse({"normal_force": "separate"})
    assert err.value.field == "normal_force"
    shared = train_surrogate(
        conflicting_pool, SurrogateConfig(ensemble_size=1, max_epochs=5, normal_force="shared"), seed=0
    )
    own = train_surrogate(
        conflicting_pool, SurrogateConfig(ensemble_size=1, max_epochs=5, normal_force="own"), 0, shared.model
    )
    warm = own.model.lineage["warm_start"]
    assert "cold: architecture" in str(warm["force"]) and warm["moment"] is True
