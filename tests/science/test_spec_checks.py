"""Shared validation: quantities state unit and range, whole numbers, and field paths of errors.

The last test walks the JSON schemas of every user-facing spec (what the web form and the API
docs show) and checks that each number says its unit and every bound it is validated against.
"""

from pathlib import Path
from typing import Annotated

import pytest
from pydantic import BaseModel, ValidationError

from alcove.errors import merge_message_path
from alcove.science.ocp.task_spec import TaskSpec
from alcove.science.oracles.aux_penalty import AuxPenaltyParams
from alcove.science.oracles.command import load_command_catalogue, params_model
from alcove.science.oracles.fe_headrest import FEHeadrestParams
from alcove.science.spec_checks import WholeNumber, error_location, quantity, range_text
from alcove.science.surrogate.config import SurrogateConfig

CATALOGUE = Path(__file__).resolve().parents[2] / "examples" / "command-oracle" / "catalogue.yaml"


@pytest.mark.parametrize(
    ("bounds", "unit", "text"),
    [
        ({"ge": 0.02, "le": 0.15}, "m", "0.02 to 0.15 m"),
        ({"gt": 0, "le": 60}, "s", "above 0, at most 60 s"),
        ({"ge": 0, "lt": 1}, "-", "at least 0, below 1"),
        ({"gt": 0}, "kg", "above 0 kg"),
        ({"gt": 0, "le": 1e8}, "Pa", "above 0, at most 1e8 Pa"),
        ({"ge": 1e-5, "le": 1.0}, "s", "1e-5 to 1 s"),
        ({}, "m", "any finite value"),
    ],
)
def test_range_text(bounds, unit, text):
    assert range_text(unit, **bounds) == text


class Sample(BaseModel):
    count: WholeNumber = 1
    length: Annotated[float, quantity("length", "m", gt=0, le=2)] = 1.0


@pytest.mark.parametrize(("value", "expected"), [(3, 3), (3.0, 3), (-2, -2)])
def test_whole_numbers_accept_integers_and_whole_floats(value, expected):
    count = Sample(count=value).count
    assert count == expected and type(count) is int


@pytest.mark.parametrize(
    ("value", "reason"),
    [
        (2.5, "Input should be a whole number, got 2.5"),
        (float("inf"), "Input should be a whole number, got inf"),
        (float("nan"), "Input should be a whole number, got nan"),
        ("3", "Input should be a whole number, not text ('3')"),
        (True, "Input should be a whole number, not true or false"),
    ],
)
def test_whole_numbers_refuse_fractions_text_and_booleans(value, reason):
    with pytest.raises(ValidationError) as info:
        Sample(count=value)
    (error,) = info.value.errors()
    assert error["loc"] == ("count",) and error["msg"] == reason


def test_a_quantity_is_bounded_finite_and_described():
    schema = Sample.model_json_schema()["properties"]["length"]
    assert schema["description"] == "length [m], above 0, at most 2 m"
    assert (schema["exclusiveMinimum"], schema["maximum"]) == (0, 2)
    for bad in (0.0, 2.5, float("inf"), float("nan")):
        with pytest.raises(ValidationError):
            Sample(length=bad)


@pytest.mark.parametrize(
    ("loc", "msg", "prefix"),
    [
        (("phases", 0, "duration"), "Input should be greater than 0", ("spec",)),
        ((), "Value error, phases.1.q_min.0: must be below q_max", ("spec",)),
        (("model",), "Value error, model.theta_max: must exceed theta_min", ("spec",)),
        ((), "Value error, element_size_far: must be at least element_size_contact", ("params",)),
        (("k",), "Value error, not a path: just a reason", ()),
        ((), "the rendered template and the output would both be 'x'", ("command_oracles", "dyna")),
    ],
)
def test_error_locations_follow_the_api_contract(loc, msg, prefix):
    """The science side names the same field as the API's alcove.errors.merge_message_path."""
    field, reason = error_location({"loc": loc, "msg": msg, "type": "value_error", "input": None}, prefix)
    api_loc, api_msg = merge_message_path([*prefix, *loc], msg)
    assert (field, reason) == (".".join(str(p) for p in api_loc), api_msg)


def number_schemas(schema: dict, path: str = "") -> list[tuple[str, dict, str]]:
    """Every numeric leaf of a JSON schema: (path, its schema, the description that explains it).

    A list's or an optional value's items inherit the description of the property when they have
    none of their own.
    """
    defs = schema.get("$defs", {})
    out: list[tuple[str, dict, str]] = []

    def walk(node: dict, where: str, description: str) -> None:
        if "$ref" in node:
            node = defs[node["$ref"].split("/")[-1]]
        description = node.get("description", description)
        if node.get("type") in ("number", "integer"):
            out.append((where, node, description))
        for key, sub in node.get("properties", {}).items():
            walk(sub, f"{where}.{key}".lstrip("."), "")
        for sub in node.get("anyOf", []):
            walk(sub, where, description)
        if isinstance(node.get("items"), dict):
            walk(node["items"], f"{where}.*", description)
        for sub in node.get("prefixItems", []):
            walk(sub, f"{where}.*", description)

    walk(schema, path, "")
    return out


def _number(value: float) -> str:
    return range_text("", ge=value, le=value).split(" to ")[0]


COMMAND_ENTRY = load_command_catalogue(CATALOGUE)["aux-replay"]
SPECS: list[type[BaseModel]] = [
    TaskSpec,
    FEHeadrestParams,
    AuxPenaltyParams,
    SurrogateConfig,
    params_model(COMMAND_ENTRY),
]


@pytest.mark.parametrize("model", SPECS, ids=lambda m: m.__name__)
def test_every_number_of_every_spec_states_its_unit_and_range(model):
    leaves = [leaf for leaf in number_schemas(model.model_json_schema()) if leaf[0] not in COMMAND_ENTRY.parameters]
    assert leaves  # (a command entry's own parameters are described by its administrator)
    for where, node, description in leaves:
        assert "[" in description and "]" in description, f"{model.__name__}.{where}: no unit in {description!r}"
        bounds = [node[k] for k in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum") if k in node]
        assert bounds, f"{model.__name__}.{where} has no range"
        for bound in bounds:
            assert _number(bound) in description, f"{model.__name__}.{where}: {bound} not in {description!r}"
