"""A new campaign's request checked whole, every problem at once and each named by its field:
the schema's checks (types, bounds, the rules within a section), the definitions it names (a
task, an oracle and a surrogate configuration the user may see, the user's own uploaded
datasets) and the rules across them (the strategy against the surrogate's ensemble, the
validation suite's and the press family's ranges on the task's model).

``POST /campaigns/check`` answers with these problems while the form is being typed, and
creating a campaign refuses with all of the problems its schema-valid request still has."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from functools import cache
from typing import Any

from pydantic import BaseModel, ValidationError, create_model
from sqlalchemy.orm import Session

from alcove.campaigns import references as refs
from alcove.campaigns.config import DEFAULT_FAMILY_MOTIONS, PreliminaryConfig, RunSettings, strategy_problem
from alcove.campaigns.schemas import CampaignCreateIn
from alcove.campaigns.sizes import campaign_size_problems
from alcove.errors import FieldError, InvalidInput, field_errors_from_pydantic
from alcove.models import OracleVersion, SurrogateConfigVersion, User
from alcove.science.oracles.builtin import AUXILIARY_LAW
from alcove.versioning import ORACLES, SURROGATE_CONFIGS, TASKS


@dataclass(frozen=True)
class Versions:
    """The definition versions a valid request names (``surrogate_config_version_id`` is None
    for the paper's default configuration, which is found or made when the campaign is created)."""

    task_version_id: int
    oracle_version_id: int
    surrogate_config_version_id: int | None


def ensemble_size(s: Session, surrogate_config_version_id: int | None) -> int:
    """The ensemble size of a surrogate configuration version (None: the paper's default)."""
    from alcove.science.surrogate.config import SurrogateConfig

    row = s.get(SurrogateConfigVersion, surrogate_config_version_id) if surrogate_config_version_id else None
    return SurrogateConfig.parse(row.spec if row is not None else {}).ensemble_size


def strategy_error(s: Session, settings: RunSettings, surrogate_config_version_id: int | None) -> FieldError | None:
    """The acquisition strategy must suit the surrogate (a problem at ``settings.strategy``)."""
    if settings.strategy == "paper":
        return None
    problem = strategy_problem(settings, ensemble_size(s, surrogate_config_version_id))
    return FieldError(("settings", "strategy"), problem) if problem is not None else None


def decided_preliminary(
    s: Session, settings: RunSettings, preliminary: PreliminaryConfig, task_version_id: int, oracle_version_id: int
) -> PreliminaryConfig:
    """``preliminary`` with ``family_motions`` decided: the request's number, or for null
    :data:`DEFAULT_FAMILY_MOTIONS` where the oracle is not the auxiliary law itself (its replays
    teach nothing its samples do not), pool version 0 is not uploaded datasets and the task's
    press family can be drawn; else 0."""
    from alcove.campaigns.suite import suite_problem
    from alcove.tasks.service import load_task

    if preliminary.family_motions is not None:
        return preliminary
    oracle = s.get(OracleVersion, oracle_version_id)
    drawn = (
        oracle is not None
        and oracle.oracle_type != AUXILIARY_LAW
        and not preliminary.dataset_ids
        and suite_problem(settings.model_copy(update={"validation_motions": 0}), load_task(s, task_version_id), True)
        is None
    )
    return preliminary.model_copy(update={"family_motions": DEFAULT_FAMILY_MOTIONS if drawn else 0})


def suite_error(
    s: Session, settings: RunSettings, preliminary: PreliminaryConfig, task_version_id: int
) -> FieldError | None:
    """The validation suite's ranges and the press family's must make motions of the task's
    model (a problem at the range)."""
    from alcove.campaigns.suite import suite_problem
    from alcove.tasks.service import load_task

    family = settings.strategy == "press-family" or preliminary.family_replays > 0
    if settings.validation_motions == 0 and not family:
        return None
    problem = suite_problem(settings, load_task(s, task_version_id), family)
    if problem is None:
        return None
    field, reason = problem
    return FieldError(tuple(int(p) if p.isdigit() else p for p in field.split(".")), reason)


@cache
def _field_model(name: str) -> type[BaseModel]:
    """A model of one field of the request, checked as the request checks it."""
    field = CampaignCreateIn.model_fields[name]
    definition: dict[str, Any] = {name: (field.annotation, field)}
    return create_model(f"CampaignCreateIn_{name}", __config__=CampaignCreateIn.model_config, **definition)


def _valid_fields(raw: dict[str, Any]) -> dict[str, Any]:
    """The request's fields that are valid on their own, parsed (absent ones with their
    defaults); a field that is not valid is left out."""
    out: dict[str, Any] = {}
    for name, field in CampaignCreateIn.model_fields.items():
        if name not in raw:
            if not field.is_required():
                out[name] = field.get_default(call_default_factory=True)
            continue
        with contextlib.suppress(ValidationError):
            out[name] = getattr(_field_model(name).model_validate({name: raw[name]}), name)
    return out


def reference_errors(s: Session, user: User, fields: dict[str, Any]) -> tuple[Versions | None, list[FieldError]]:
    """The definitions the request names and the rules across them, for the fields that are
    valid on their own (``fields``: field name -> parsed value; a field left out was named by
    the schema's check). Every problem is collected; the versions when there is none."""
    errors: list[FieldError] = []

    def version(kind: Any, id_field: str, version_field: str) -> int | None:
        if fields.get(id_field) is None or version_field not in fields:
            return None
        try:
            return refs.version_id(s, user, kind, fields[id_field], fields[version_field], id_field)
        except InvalidInput as err:
            errors.extend(err.errors)
            return None

    task = version(TASKS, "task_id", "task_version")
    oracle = version(ORACLES, "oracle_id", "oracle_version")
    surrogate = version(SURROGATE_CONFIGS, "surrogate_config_id", "surrogate_config_version")
    # the paper's default (no id), or a version found
    surrogate_known = "surrogate_config_id" in fields and (fields["surrogate_config_id"] is None or bool(surrogate))
    preliminary: PreliminaryConfig | None = fields.get("preliminary")
    settings: RunSettings | None = fields.get("settings")
    if preliminary is not None and preliminary.dataset_ids:
        try:
            refs.check_datasets(s, user, preliminary.dataset_ids, task)
        except InvalidInput as err:
            errors.extend(err.errors)
    if settings is not None and surrogate_known:
        found = strategy_error(s, settings, surrogate)
        errors.extend([found] if found else [])
    if settings is not None and preliminary is not None and task is not None:
        found = suite_error(s, settings, preliminary, task)
        errors.extend([found] if found else [])
    errors.extend(campaign_size_problems(s, user, preliminary, settings, task, surrogate))
    if errors or task is None or oracle is None or not surrogate_known:
        return None, errors
    return Versions(task, oracle, surrogate), errors


def check_request(s: Session, user: User, raw: dict[str, Any]) -> tuple[CampaignCreateIn | None, list[FieldError]]:
    """A new campaign's request (any JSON object) checked whole: the parsed request when it is
    valid, and every problem (the schema's, then those of the definitions and across them)."""
    try:
        body: CampaignCreateIn | None = CampaignCreateIn.model_validate(raw)
        errors: list[FieldError] = []
        fields = dict(body) if body is not None else {}
    except ValidationError as err:
        body, errors, fields = None, field_errors_from_pydantic(err), _valid_fields(raw)
    _, more = reference_errors(s, user, fields)
    return (body if not more else None), errors + more


def versions_of(s: Session, user: User, body: CampaignCreateIn) -> Versions:
    """The versions a schema-valid request names; :class:`InvalidInput` with every problem."""
    versions, errors = reference_errors(s, user, dict(body))
    if errors or versions is None:
        raise InvalidInput(errors)
    return versions
