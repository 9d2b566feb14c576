"""The input rules an OpenAPI schema cannot state, written into each operation's 422 answer.

Most of what the API refuses, the schema says (types, bounds, patterns, required fields). Some
rules it cannot: rules across fields (a range's low end below its high end, one value per joint
of the task's model), ids that must name an object of the caller's, an uploaded file's content,
the caller's job limits, and the NUL rule below the top level of a free-form JSON body (the
schema states it for the top-level keys). A schema-valid request that breaks one of them gets a
422 naming the field and the rule; this module names those rules in the 422 description of each
operation that has them, so the schema says what the API does."""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI

#: operation id -> the rules beyond the schema that its 422 may name
RULES_BEYOND_THE_SCHEMA: dict[str, str] = {
    "create_campaign": "the definitions and datasets named must be yours; ranges low <= high; job limits",
    "update_campaign_config": "the surrogate config version named must be yours; ranges low <= high; job limits",
    "fork_campaign": "the versions named must be yours; ranges low <= high; job limits",
    "create_task": "the spec's rules across fields (one value per joint, q_min < q_max, ranged parameters)",
    "update_task": "the spec's rules across fields",
    "create_task_preview": "the version named must exist; the spec's rules across fields; job limits",
    "preview_task_scenarios": "the spec's rules across fields",
    "create_oracle": "the type names a built-in type or a catalogue entry; its parameters are that type's",
    "update_oracle": "the type names a built-in type or a catalogue entry; its parameters are that type's",
    "create_oracle_preview": "the version named must exist; the parameters are the oracle type's",
    "create_surrogate_config": "the spec's rules across fields; job limits",
    "update_surrogate_config": "the spec's rules across fields; job limits",
    "upload_preliminary_dataset": "the file is a CSV of the documented columns",
    "create_share": "the object named must be yours, the e-mail not yours",
    "check_task": "a NUL in a key or text below the spec's top level",
    "check_oracle": "a NUL in a key or text below the params' top level",
    "check_surrogate_config": "a NUL in a key or text below the spec's top level",
    "check_campaign": "a NUL in a key or text below the request's top level",
}


def state_the_input_rules(schema: dict[str, Any]) -> dict[str, Any]:
    """``schema`` with each listed operation's 422 description naming its rules beyond the schema."""
    for path_item in schema.get("paths", {}).values():
        for operation in path_item.values():
            rules = (
                RULES_BEYOND_THE_SCHEMA.get(operation.get("operationId", "")) if isinstance(operation, dict) else None
            )
            answer = operation.get("responses", {}).get("422") if rules else None
            if answer is not None:
                answer["description"] = f"{answer['description']}; also refused, beyond this schema: {rules}"
    return schema


def install_input_rules(app: FastAPI) -> None:
    """Make ``app``'s OpenAPI document name the rules beyond the schema (:func:`state_the_input_rules`)."""
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            app.openapi_schema = state_the_input_rules(generate())
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
