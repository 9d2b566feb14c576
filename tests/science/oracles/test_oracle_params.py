"""Oracle parameters: every number has a plausible physical range, and a bad value names its field.

Bad values of every kind (too large, not finite, not a whole number, outside what the model
can take) go through the registry, as the CLI and the campaigns see them, and through the
API's field errors; realistic values, the defaults and the paper's settings still pass.
"""

import copy
import sys
from pathlib import Path

import pytest
from pydantic import ValidationError

from alcove.errors import field_errors_from_pydantic
from alcove.science.oracles.aux_penalty import AuxPenaltyParams
from alcove.science.oracles.base import OracleInputError
from alcove.science.oracles.command import CatalogueError, load_command_catalogue, params_model
from alcove.science.oracles.fe_headrest import FEHeadrestParams
from alcove.science.oracles.registry import build_oracle

CATALOGUE = Path(__file__).resolve().parents[3] / "examples" / "command-oracle" / "catalogue.yaml"

# (parameter, a realistic value other than the default) for every number of the FE oracle
FE_NUMBERS = [
    ("cushion_thickness", 0.06),
    ("cushion_height", 0.25),
    ("cushion_bottom", -0.12),
    ("out_of_plane_width", 0.15),
    ("head_half_breadth", 0.08),
    ("element_size_contact", 0.005),
    ("element_size_far", 0.012),
    ("contact_zone.0", -0.05),
    ("contact_zone.1", 0.06),
    ("foam_mu.0", 1e5),
    ("foam_alpha.0", 10.0),
    ("foam_beta.0", 0.1),
    ("viscosity", 500.0),
    ("penalty", 1e9),
    ("friction", 0.3),
    ("friction_regularization_velocity", 0.01),
    ("output_dt", 0.005),
    ("moment_point.0", 0.01),
    ("moment_point.1", -0.02),
    ("newton_tolerance", 1e-7),
    ("max_penetration", 5e-4),
    ("energy_tolerance", 0.05),
    ("reaction_tolerance", 2e-3),
    ("max_indentation_fraction", 0.5),
]
FE_WHOLE_NUMBERS = [("slices", 3), ("substeps", 2), ("newton_max_iterations", 30)]
AUX_NUMBERS = [("k", 1.2e7), ("d0", 50.0), ("p_ref", 0.003), ("r_sp.0", -0.1), ("r_sp.2", -0.03)]


def with_value(defaults: dict, path: str, value: object) -> dict:
    """The parameters ``defaults`` with ``value`` at ``path`` (``name`` or ``name.index`` of a tuple)."""
    params = copy.deepcopy(defaults)
    name, _, index = path.partition(".")
    if index:
        items = list(params[name] if params.get(name) is not None else [0.0, 0.0, 0.0])
        items[int(index)] = value
        params[name] = items
    else:
        params[name] = value
    return params


def fe(path: str, value: object) -> dict:
    return with_value(FEHeadrestParams().model_dump(), path, value)


def refused(type_name: str, params: dict, catalogue: dict | None = None) -> OracleInputError:
    with pytest.raises(OracleInputError) as info:
        build_oracle(type_name, params, catalogue=catalogue)
    return info.value


@pytest.mark.parametrize("path", [p for p, _ in FE_NUMBERS + FE_WHOLE_NUMBERS])
def test_fe_numbers_too_large_name_the_field(path):
    err = refused("fe-headrest-2d", fe(path, 1e308))
    assert err.field == f"params.{path}" and "less than or equal to" in err.reason


@pytest.mark.parametrize("value", [float("nan"), float("inf"), float("-inf")])
@pytest.mark.parametrize("path", [p for p, _ in FE_NUMBERS])
def test_fe_numbers_must_be_finite(path, value):
    err = refused("fe-headrest-2d", fe(path, value))
    assert err.field == f"params.{path}" and "finite number" in err.reason


@pytest.mark.parametrize(
    ("value", "reason"),
    [(2.5, "whole number, got 2.5"), ("2", "whole number, not text"), (True, "whole number, not true or false")],
)
@pytest.mark.parametrize("path", [p for p, _ in FE_WHOLE_NUMBERS])
def test_fe_counts_are_whole_numbers(path, value, reason):
    """slices = 2.5 is refused naming the field: it never becomes 2."""
    err = refused("fe-headrest-2d", fe(path, value))
    assert err.field == f"params.{path}" and reason in err.reason


@pytest.mark.parametrize(
    ("params", "field", "reason"),
    [
        (
            {"element_size_contact": 0.004, "element_size_far": 0.003},
            "element_size_far",
            "at least element_size_contact",
        ),
        ({"cushion_thickness": 0.02, "element_size_contact": 0.006}, "element_size_contact", "cushion_thickness / 4"),
        ({"contact_zone": [0.05, -0.05]}, "contact_zone.1", "must exceed the low end 0.05 m"),
        ({"contact_zone": [-0.2, 0.05]}, "contact_zone.0", "below the cushion's bottom face -0.1 m"),
        ({"contact_zone": [-0.05, 0.2]}, "contact_zone.1", "above the cushion's top face 0.12 m"),
        ({"cushion_bottom": -0.3, "cushion_height": 0.25}, "cushion_height", "above the first-contact point"),
        ({"foam_alpha": [0.0, -2.04]}, "foam_alpha.0", "must not be 0"),
        ({"foam_mu": [1e4], "foam_alpha": [2.0, 3.0], "foam_beta": [0.0]}, "foam_alpha", "one term per modulus"),
        ({"foam_mu": [-1e4, 1.54e3]}, "foam_mu.0", "greater than 0"),
    ],
)
def test_fe_values_the_model_cannot_take_name_the_field(params, field, reason):
    err = refused("fe-headrest-2d", params)
    assert err.field == f"params.{field}" and reason in err.reason


@pytest.mark.parametrize(
    ("params", "field"),
    [
        ({"slices": 2.5}, "params.slices"),
        ({"penalty": 1e308}, "params.penalty"),
        ({"contact_zone": [0.05, -0.05]}, "params.contact_zone.1"),
        ({"element_size_contact": 0.004, "element_size_far": 0.003}, "params.element_size_far"),
    ],
)
def test_the_api_reports_the_same_field(params, field):
    """The oracle editor's field errors (alcove.errors) name the same parameter as the registry."""
    with pytest.raises(ValidationError) as info:
        FEHeadrestParams.model_validate(params)
    assert field_errors_from_pydantic(info.value, base=("params",))[0].field == field


def test_realistic_fe_parameters_pass():
    """Defaults (the paper's reproduction uses them), a realistic other value of every number, and the
    settings the tests and docs use."""
    assert build_oracle("fe-headrest-2d", {}).params == FEHeadrestParams()
    for path, value in FE_NUMBERS + FE_WHOLE_NUMBERS:
        build_oracle("fe-headrest-2d", fe(path, value))
    FEHeadrestParams(element_size_contact=0.003, element_size_far=0.0075, substeps=2, slices=3)
    FEHeadrestParams(cushion_thickness=0.02, element_size_contact=0.004, max_indentation_fraction=0.3)
    assert FEHeadrestParams(slices=2.0).slices == 2  # a whole number written as a float


@pytest.mark.parametrize(("path", "value"), AUX_NUMBERS)
def test_aux_penalty_numbers(path, value):
    defaults = AuxPenaltyParams().model_dump()
    params = with_value(defaults, path, value)
    assert build_oracle("aux-penalty", params).params == AuxPenaltyParams.model_validate(params)
    too_large = refused("aux-penalty", with_value(defaults, path, 1e308))
    assert too_large.field == f"params.{path}" and "less than or equal to" in too_large.reason
    for bad in (float("nan"), float("inf")):
        err = refused("aux-penalty", with_value(defaults, path, bad))
        assert err.field == f"params.{path}" and "finite number" in err.reason


def command_catalogue(tmp_path: Path, parameter: str) -> dict:
    path = tmp_path / "catalogue.yaml"
    path.write_text(f"command_oracles:\n  solver:\n    argv: [{sys.executable}]\n{parameter}")
    return load_command_catalogue(path)


def test_command_oracle_numbers():
    catalogue = load_command_catalogue(CATALOGUE)
    oracle = build_oracle("aux-replay", {"dt_out": 0.001, "k": 2e6}, catalogue=catalogue)
    assert oracle.params.dt_out == 0.001 and oracle.params.k == 2e6
    for params, field, reason in [
        ({"dt_out": 1e308}, "params.dt_out", "less than or equal to 1"),
        ({"dt_out": 1e-9}, "params.dt_out", "greater than or equal to 0.00001"),
        ({"dt_out": float("nan")}, "params.dt_out", "finite number"),
        ({"k": 1e308}, "params.k", "less than or equal to 1000000000"),
        ({"k": float("inf")}, "params.k", "finite number"),
    ]:
        err = refused("aux-replay", params, catalogue)
        assert err.field == field and reason in err.reason
    schema = params_model(catalogue["aux-replay"]).model_json_schema()["properties"]["dt_out"]
    assert (schema["minimum"], schema["maximum"]) == (1e-5, 1.0) and "[s], 1e-5 to 1 s" in schema["description"]


@pytest.mark.parametrize(
    ("entry", "field", "reason"),
    [
        ("    timeout_s: 1.0e+308\n", "command_oracles.solver.timeout_s", "less than or equal to 604800"),
        ("    timeout_s: .inf\n", "command_oracles.solver.timeout_s", "finite number"),
        ("    parameters: {k: {default: .nan}}\n", "command_oracles.solver.parameters.k.default", "finite number"),
        ("    parameters: {k: {default: 1, maximum: .inf}}\n", "command_oracles.solver.parameters.k.maximum", "finite"),
    ],
)
def test_catalogue_numbers_name_the_entry_and_key(tmp_path, entry, field, reason):
    with pytest.raises(CatalogueError) as info:
        command_catalogue(tmp_path, entry)
    assert info.value.field == field and reason in info.value.reason
