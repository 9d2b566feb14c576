"""Find-or-create the definition versions a campaign needs from built-in presets (the CLI, the
reproduction scripts, benchmarks and tests).

A definition is reused when the owner already has one from the same preset whose latest
version has the same content (``spec_hash``); otherwise it is created as the API creates one,
through its domain's service (:func:`alcove.tasks.service.create`,
:func:`alcove.oracles.service.create`, :func:`alcove.surrogates.service.create_config`). A bad
value raises the science's field error (``TaskSpecError``, ``OracleInputError``,
``SurrogateConfigError``), which names the field.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from alcove.errors import NotFound
from alcove.models import Role, User, spec_hash
from alcove.users import repository as users_repo
from alcove.versioning import ORACLES, SURROGATE_CONFIGS, TASKS, preset_version_id


def local_user(s: Session, email: str = "admin@alcove.local") -> User:
    """The first admin (created if there is none) who owns CLI-made campaigns."""
    user = users_repo.first_admin(s) or users_repo.user_by_email(s, email)
    if user is None:
        user = User(email=email, display_name="Administrator", role=Role.admin.value)
        s.add(user)
        s.flush()
    return user


def _owner(s: Session, owner_id: int) -> User:
    user = s.get(User, owner_id)
    if user is None:
        raise NotFound("user", owner_id)
    return user


def task_version_from_preset(s: Session, owner_id: int, preset: str, spec: dict[str, Any] | None = None) -> int:
    from alcove.science.ocp.task_spec import parse_task, task_preset
    from alcove.tasks import service as tasks

    # a given spec is validated like the API's (TaskSpecError names the field) and stored normalised
    task = parse_task(spec) if spec is not None else task_preset(preset)
    found = preset_version_id(s, TASKS, owner_id, preset, spec_hash(tasks.dump(task)), {})
    if found is not None:
        return found
    _, version = tasks.create(s, _owner(s, owner_id), name=preset, description="", spec=task, preset_key=preset)
    return int(version.id)


def oracle_version_for(s: Session, owner_id: int, oracle_type: str, params: dict[str, Any] | None = None) -> int:
    from alcove.oracles import service as oracles
    from alcove.science.oracles.registry import BUILTIN_TYPE_NAMES, build_oracle

    catalogue = None if oracle_type in BUILTIN_TYPE_NAMES else oracles.command_catalogue(s)
    # validates; raises OracleInputError naming the field
    body = build_oracle(oracle_type, params or {}, catalogue=catalogue).params.model_dump(mode="json")
    found = preset_version_id(s, ORACLES, owner_id, oracle_type, spec_hash(body), {"oracle_type": oracle_type})
    if found is not None:
        return found
    _, version = oracles.create(
        s,
        _owner(s, owner_id),
        name=oracle_type,
        description="",
        type_name=oracle_type,
        params=body,
        preset_key=oracle_type,
    )
    return int(version.id)


def surrogate_config_version_for(s: Session, owner_id: int, config: dict[str, Any] | None = None) -> int:
    from alcove.science.surrogate.config import SurrogateConfig
    from alcove.surrogates import service as surrogates

    spec = SurrogateConfig.parse(config or {})  # SurrogateConfigError names the field
    found = preset_version_id(
        s, SURROGATE_CONFIGS, owner_id, "paper-default", spec_hash(spec.model_dump(mode="json")), {}
    )
    if found is not None:
        return found
    _, version = surrogates.create_config(
        s, _owner(s, owner_id), name="surrogate", description="", spec=spec, preset_key="paper-default"
    )
    return int(version.id)
