"""Surrogate configuration: every number has a range; a bad value of any kind names its field."""

import pytest
from pydantic import ValidationError

from alcove.errors import field_errors_from_pydantic
from alcove.science.surrogate.config import SurrogateConfig, SurrogateConfigError

NUMBERS = ["learning_rate", "test_fraction", "validation_fraction", "preliminary_weight", "preliminary_halving"]
WHOLE_NUMBERS = ["batch_size", "patience", "max_epochs", "seed", "force.hidden.1", "moment.hidden.0"]


def config_with(path: str, value: object) -> dict:
    """A configuration (as JSON data) with ``value`` at a dotted path such as ``force.hidden.1``."""
    name, _, rest = path.partition(".")
    if not rest:
        return {name: value}
    hidden = list(SurrogateConfig().model_dump()[name]["hidden"])
    hidden[int(rest.removeprefix("hidden."))] = value
    return {name: {"hidden": hidden}}


def refused(data: dict) -> SurrogateConfigError:
    with pytest.raises(SurrogateConfigError) as info:
        SurrogateConfig.parse(data)
    return info.value


@pytest.mark.parametrize(
    ("path", "reason"),
    [
        ("learning_rate", "less than or equal to 1"),
        ("test_fraction", "less than 1"),
        ("validation_fraction", "less than 1"),
        ("preliminary_weight", "less than or equal to 1000000"),
        ("preliminary_halving", "less than or equal to 1000000"),
        ("batch_size", "less than or equal to 1000000"),
        ("patience", "less than or equal to 1000"),
        ("max_epochs", "less than or equal to 100000"),
        ("seed", "less than or equal to 9223372036854775807"),
        ("force.hidden.1", "less than or equal to 4096"),
    ],
)
def test_too_large_values_name_the_field(path, reason):
    err = refused(config_with(path, 1e308))
    assert err.field == path and reason in err.reason


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
@pytest.mark.parametrize("path", NUMBERS)
def test_numbers_must_be_finite(path, value):
    err = refused(config_with(path, value))
    assert err.field == path and "finite number" in err.reason


@pytest.mark.parametrize(
    ("value", "reason"),
    [(2.5, "whole number, got 2.5"), ("8", "whole number, not text"), (True, "whole number, not true or false")],
)
@pytest.mark.parametrize("path", WHOLE_NUMBERS)
def test_counts_are_whole_numbers(path, value, reason):
    err = refused(config_with(path, value))
    assert err.field == path and reason in err.reason


def test_the_api_reports_the_same_field():
    with pytest.raises(ValidationError) as info:
        SurrogateConfig.model_validate({"force": {"hidden": [6, 2.5, 4]}})
    assert field_errors_from_pydantic(info.value, base=("spec",))[0].field == "spec.force.hidden.1"


def test_realistic_configurations_pass():
    """The paper's defaults, the reproduction's settings (scripts/reproduce.py) and those of the tests."""
    paper = SurrogateConfig.parse({})
    assert (paper.force.hidden, paper.moment.hidden, paper.batch_size) == ((6, 6, 4), (6, 6, 6, 4), 1024)
    for data in [
        {"max_epochs": 30},
        {"preliminary_weight": 0.1},
        {"max_epochs": 60, "batch_size": 256, "force": {"hidden": [8, 8]}},
        {"preliminary_weight": 2.0, "preliminary_halving": 20, "seed": 2**63 - 1, "dtype": "float32"},
        {"learning_rate": 1.0, "test_fraction": 0.0, "validation_fraction": 0.5, "patience": 1000},
    ]:
        config = SurrogateConfig.parse(data)
        for key, value in data.items():
            if key == "force":
                assert list(config.force.hidden) == value["hidden"]
            else:
                assert getattr(config, key) == value
    assert SurrogateConfig.parse({"batch_size": 512.0}).batch_size == 512  # a whole number written as a float
