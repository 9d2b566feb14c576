"""A trained surrogate as the OCP's contact: the weights as NLP parameters.

One contact function per architecture, so the NLP and IPOPT solver are built once and every
new model version only changes the parameter values; the optimum is the one of the
surrogate with its weights as constants.
"""

from concurrent.futures import ThreadPoolExecutor

import casadi as ca
import numpy as np
import pytest

from alcove.science.ocp.solve import get_transcription, solve_task
from alcove.science.ocp.task_spec import task_preset
from alcove.science.surrogate.casadi_contact import casadi_contact_function, surrogate_contact, surrogate_parameters
from alcove.science.surrogate.config import SurrogateConfig
from alcove.science.surrogate.preliminary import preliminary_pool
from alcove.science.surrogate.training import train_surrogate


@pytest.fixture(scope="module")
def task():
    return task_preset("head-headrest-2phase").with_intervals(50)


@pytest.fixture(scope="module")
def models(task):
    """Two consecutive model versions (the second warm-started from the first), as in a campaign."""
    preset = task.preset()
    pool = preliminary_pool(preset, samples=600)
    config = SurrogateConfig(max_epochs=60)
    first = train_surrogate(pool, config, seed=0, preset=preset).model
    second = train_surrogate(pool, config, seed=1, preset=preset, warm_start=first).model
    return first, second


def test_parametric_export_has_the_values_and_derivatives_of_the_constant_one(task, models):
    preset = task.preset()
    rng = np.random.default_rng(0)
    q = rng.uniform(preset.theta_min, preset.theta_max, 40)[None, :]
    qd = rng.uniform(-3, 3, 40)[None, :]
    for model in models:
        fixed = casadi_contact_function(model, preset)
        fn, p = surrogate_contact(model, preset)
        assert fn.name_in() == ["q", "qd", "p"] and p.shape == (fn.size1_in(2),)
        a = np.asarray(fixed.map(40)(q, qd))
        b = np.asarray(fn.map(40)(q, qd, ca.repmat(ca.DM(p), 1, 40)))
        np.testing.assert_allclose(b, a, rtol=1e-10, atol=1e-10 * np.abs(a).max())
        # the OCP differentiates in (q, qd): the Jacobians agree too
        y = ca.SX.sym("y", 2)
        jf = ca.Function("jf", [y], [ca.jacobian(fixed(y[0], y[1]), y)])
        jp = ca.Function("jp", [y], [ca.jacobian(fn(y[0], y[1], ca.DM(p)), y)])
        for k in range(0, 40, 8):
            ja, jb = np.asarray(jf([q[0, k], qd[0, k]])), np.asarray(jp([q[0, k], qd[0, k]]))
            np.testing.assert_allclose(jb, ja, rtol=1e-9, atol=1e-9 * np.abs(ja).max())


def test_a_net_of_blocks_passes_only_its_blocks_weights_to_the_nlp(task, models):
    """The default force net gives the normal force layers of its own: the weights between its
    blocks are zero and are not parameters of the NLP (nor products in its graph)."""
    model = models[0]
    assert model.force_net.blocks == ((0,), (1, 2))
    in_blocks = sum(int(m.sum()) for m in model.force_net.masks())
    dense = sum(lin.weight.numel() for lin in model.force_net.linears())
    assert in_blocks < dense
    per_member = (
        in_blocks
        + sum(lin.out_features for lin in model.force_net.linears())
        + sum(lin.weight.numel() + lin.out_features for lin in model.moment_net.linears())
        + 2 * (3 + 3)  # output scale and mean of both nets
    )
    fn, p = surrogate_contact(model, task.preset())
    assert p.size == fn.size1_in(2) == model.ensemble_size * per_member


def test_one_function_per_architecture_and_parameters_per_model(task, models):
    preset = task.preset()
    (fn1, p1), (fn2, p2) = (surrogate_contact(m, preset) for m in models)
    assert fn1 is fn2  # same architecture: same function, same NLP
    with ThreadPoolExecutor(1) as pool:  # SX graphs are not shared between threads
        elsewhere = pool.submit(lambda: surrogate_contact(models[0], preset)[0]).result()
    assert elsewhere is not fn1 and elsewhere.serialize() == fn1.serialize()
    assert p1.shape == p2.shape and not np.allclose(p1, p2)
    np.testing.assert_array_equal(surrogate_parameters(models[1]), p2)
    # another architecture is another function
    other = SurrogateConfig(force={"hidden": [5]}, moment={"hidden": [4, 3]}, max_epochs=2)
    small = train_surrogate(preliminary_pool(preset, samples=100), other, seed=0, preset=preset).model
    fn3, p3 = surrogate_contact(small, preset)
    assert fn3 is not fn1 and p3.size == fn3.size1_in(2) != p1.size


def test_a_new_model_version_reuses_the_nlp_and_finds_the_same_optimum(task, models):
    """Same start, same optimum as with the weights as constants (the problem is not convex:
    another start may find another local optimum, so each run is compared with its twin)."""
    preset = task.preset()
    _, second = models
    (fn, p1), (_, p2) = (surrogate_contact(m, preset) for m in models)
    previous = solve_task(task, fn, contact_params=p1)
    assert previous.converged
    tr = get_transcription(task, fn)
    fixed = casadi_contact_function(second, preset)  # weights as constants
    for guess in (previous, None):  # warm start from the previous version's solution, passive guess
        current = solve_task(task, fn, contact_params=p2, initial_guess=guess)
        assert get_transcription(task, fn) is tr  # no rebuild for the new weights
        reference = solve_task(task, fixed, initial_guess=guess)
        assert current.converged and reference.converged
        assert current.attempts[0]["guess"] == reference.attempts[0]["guess"] == ("previous" if guess else "passive")
        assert current.cost == pytest.approx(reference.cost, rel=1e-6)
        np.testing.assert_allclose(current.q, reference.q, atol=1e-6)
        np.testing.assert_allclose(current.controls, reference.controls, atol=1e-4 * np.abs(reference.controls).max())
    # the parameters matter: the first model's optimum is another one
    assert abs(previous.cost - current.cost) > 1e-6 * abs(current.cost) or np.abs(previous.q - current.q).max() > 1e-6


def test_output_normalisation_must_match_the_networks(task, models):
    import copy

    broken = copy.deepcopy(models[0])
    broken.force_norm = type(broken.force_norm)(np.zeros(2), np.ones(2))
    with pytest.raises(ValueError, match=r"^model: "):
        surrogate_contact(broken, task.preset())
