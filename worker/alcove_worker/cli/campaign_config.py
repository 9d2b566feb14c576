"""What `alcove campaign run` and `alcove campaign create` share: reading ``--config`` and
creating the campaign (validated where the API validates it; an error names the field)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from alcove_worker.cli.follow import fail


def read_config(path: Path | None) -> dict[str, Any]:
    if path is None:
        return {}
    if not path.exists():
        fail("--config", f"{path} does not exist")
    text = path.read_text()
    try:
        if path.suffix.lower() == ".json":
            data = json.loads(text)
        else:
            import yaml

            data = yaml.safe_load(text)
    except Exception as exc:
        fail("--config", f"cannot parse {path}: {exc}")
    if data is None:
        return {}
    if not isinstance(data, dict):
        fail("--config", "must be a mapping")
    known = {
        "name",
        "description",
        "seed",
        "preliminary",
        "stopping",
        "policies",
        "settings",
        "surrogate",
        "oracle_params",
        "task_spec",
    }
    unknown = sorted(set(data) - known)
    if unknown:
        fail(f"--config.{unknown[0]}", f"unknown key (known: {', '.join(sorted(known))})")
    return data


def ensure_database() -> None:
    from alcove.db import migrate
    from alcove.settings import get_settings

    s = get_settings()
    if s.is_sqlite:
        s.data_dir.mkdir(parents=True, exist_ok=True)
        migrate.upgrade()
    elif not migrate.is_up_to_date():
        fail("database", "not migrated to the code's head revision; run `alcove db upgrade`")


def create_campaign(
    task: str, oracle: str, iterations: int | None, cfg: dict[str, Any], name: str | None, seed: int | None
) -> int:
    from pydantic import ValidationError

    from alcove.campaigns import presets, service
    from alcove.campaigns.schemas import CampaignCreate
    from alcove.db import run_transaction
    from alcove.errors import InvalidInput
    from alcove.science.errors import FieldError

    def section(name: str, given: Any, make: Any) -> Any:
        """``make()``, with a bad value's field named inside its --config section (``surrogate.x``)."""
        try:
            return make()
        except FieldError as exc:
            if given is None:  # the preset's own values: the error is not the config's
                raise
            field = exc.field.removeprefix("params.") if name == "oracle_params" else exc.field
            raise FieldError(f"{name}.{field}", exc.reason) from exc

    def work(s: Any) -> int:
        user = presets.local_user(s)
        spec, params, surrogate = cfg.get("task_spec"), cfg.get("oracle_params"), cfg.get("surrogate")
        tv = section("task_spec", spec, lambda: presets.task_version_from_preset(s, user.id, task, spec))
        ov = section("oracle_params", params, lambda: presets.oracle_version_for(s, user.id, oracle, params))
        sv = section("surrogate", surrogate, lambda: presets.surrogate_config_version_for(s, user.id, surrogate))
        stopping = dict(cfg.get("stopping") or {})
        if iterations is not None:
            stopping["max_iterations"] = iterations
        data = CampaignCreate.model_validate(
            {
                "name": name or cfg.get("name") or f"{task} x {oracle}",
                "description": cfg.get("description", ""),
                "task_version_id": tv,
                "oracle_version_id": ov,
                "surrogate_config_version_id": sv,
                "seed": seed if seed is not None else cfg.get("seed", 0),
                "preliminary": cfg.get("preliminary") or {},
                "stopping": stopping,
                "policies": cfg.get("policies") or {},
                "settings": cfg.get("settings") or {},
            }
        )
        return service.create_campaign(s, user.id, data).id

    try:
        return run_transaction(work)
    except ValidationError as exc:
        err = exc.errors()[0]
        fail(".".join(str(p) for p in err["loc"]) or "config", err["msg"])
    except ValueError as exc:  # the science modules' input errors name the field
        fail(getattr(exc, "field", "config"), getattr(exc, "reason", str(exc)))
    except InvalidInput as exc:  # the service's cross-definition checks (e.g. settings.strategy)
        fail(exc.errors[0].field, exc.errors[0].msg)
    raise AssertionError("unreachable")
