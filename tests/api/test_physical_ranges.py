"""Every number a user gives a task, an oracle, a surrogate config or a campaign has a
plausible range: bounded on both sides in the JSON Schema (what the API validates and the
forms show) and stated in words in its description, so that 1e300 for gravity or 1e308 for
a duration is refused when it is entered, not in the solver."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from alcove.campaigns.config import CampaignConfig
from alcove.science.ocp.task_spec import TaskSpec
from alcove.science.oracles.registry import params_json_schema
from alcove.science.surrogate.config import SurrogateConfig

#: integers that count things (no physical unit) need only be bounded, not described
RANGE_WORDS = (" to ", "at most", "below", "at least", "above")


def numbers(schema: dict[str, Any], defs: dict[str, Any], path: str = "") -> Iterator[tuple[str, dict[str, Any]]]:
    if "$ref" in schema:
        yield from numbers(defs[schema["$ref"].rsplit("/", 1)[1]], defs, path)
        return
    for key in ("anyOf", "oneOf", "allOf"):
        for sub in schema.get(key, []):
            yield from numbers(
                {**sub, "description": sub.get("description", schema.get("description", ""))}, defs, path
            )
    if schema.get("type") in ("number", "integer"):
        yield path, schema
    for name, sub in schema.get("properties", {}).items():
        yield from numbers({**sub, "description": sub.get("description", "")}, defs, f"{path}.{name}".lstrip("."))
    items = schema.get("items")
    if isinstance(items, dict):
        yield from numbers(
            {**items, "description": items.get("description", schema.get("description", ""))}, defs, f"{path}.N"
        )
    for i, item in enumerate(schema.get("prefixItems", [])):
        yield from numbers(
            {**item, "description": item.get("description", schema.get("description", ""))}, defs, f"{path}.{i}"
        )


def schemas() -> dict[str, dict[str, Any]]:
    out = {
        "task": TaskSpec.model_json_schema(),
        "surrogate config": SurrogateConfig.model_json_schema(),
        "campaign config": CampaignConfig.model_json_schema(),
    }
    for oracle_type in ("aux-penalty", "fe-headrest-2d", "fe-headrest-3d-ccx"):
        out[f"oracle {oracle_type}"] = params_json_schema(oracle_type)
    return out


@pytest.mark.parametrize("which", sorted(schemas()))
def test_every_number_is_bounded_and_its_range_described(which: str) -> None:
    schema = schemas()[which]
    defs = schema.get("$defs", {})
    unbounded, undescribed = [], []
    found = 0
    for path, s in numbers(schema, defs):
        found += 1
        if ("minimum" not in s and "exclusiveMinimum" not in s) or ("maximum" not in s and "exclusiveMaximum" not in s):
            unbounded.append(path)
        elif s.get("type") == "number" and not any(w in s.get("description", "") for w in RANGE_WORDS):
            undescribed.append(path)
    assert found > 3
    assert not unbounded, f"{which}: numbers without a lower and an upper bound: {unbounded}"
    assert not undescribed, f"{which}: numbers whose description does not state the range: {undescribed}"
