"""The schema names the rules it cannot state: each operation that refuses schema-valid requests
by a rule beyond the schema says which in its 422 answer (alcove.api.input_rules)."""

from __future__ import annotations

from fastapi.testclient import TestClient

from alcove.api.input_rules import RULES_BEYOND_THE_SCHEMA
from alcove.app import create_app


def test_each_operation_with_rules_beyond_the_schema_names_them_in_its_422() -> None:
    schema = TestClient(create_app()).get("/api/v1/openapi.json").json()
    operations = {
        op["operationId"]: op for item in schema["paths"].values() for op in item.values() if isinstance(op, dict)
    }
    assert set(RULES_BEYOND_THE_SCHEMA) <= set(operations), set(RULES_BEYOND_THE_SCHEMA) - set(operations)
    for operation_id, rules in RULES_BEYOND_THE_SCHEMA.items():
        description = operations[operation_id]["responses"]["422"]["description"]
        assert description.endswith(f"also refused, beyond this schema: {rules}"), (operation_id, description)
    # an operation whose 422 is the schema's own keeps the common words
    assert operations["create_token"]["responses"]["422"]["description"] == "invalid input: field paths and reasons"
