"""Find-or-create the definition versions a campaign needs from built-in presets (used by
the CLI and tests; the REST API goes through the tasks/oracles services instead).

A definition is reused when the owner already has one from the same preset whose latest
version has the same content (``spec_hash``); otherwise a new definition is created.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from alcove.models import Role, User, spec_hash
from alcove.users import repository as users_repo
from alcove.versioning import ORACLES, SURROGATE_CONFIGS, TASKS, D, Kind, V, preset_version_id


def local_user(s: Session, email: str = "admin@alcove.local") -> User:
    """The first admin (created if there is none) who owns CLI-made campaigns."""
    user = users_repo.first_admin(s) or users_repo.user_by_email(s, email)
    if user is None:
        user = User(email=email, display_name="Administrator", role=Role.admin.value)
        s.add(user)
        s.flush()
    return user


def _find_or_create(
    s: Session,
    owner_id: int,
    kind: Kind[D, V],
    preset_key: str,
    name: str,
    spec: dict[str, Any],
    **version_fields: Any,
) -> int:
    definition_cls, version_cls = kind.definition, kind.version
    h = spec_hash(spec)
    found = preset_version_id(s, kind, owner_id, preset_key, h, version_fields)
    if found is not None:
        return found
    d = definition_cls(owner_id=owner_id, name=name, preset_key=preset_key, latest_version=1)
    s.add(d)
    s.flush()
    version = version_cls(
        version=1, spec=spec, spec_hash=h, created_by_id=owner_id, **{kind.parent_key: d.id}, **version_fields
    )
    s.add(version)
    s.flush()
    return version.id


def task_version_from_preset(s: Session, owner_id: int, preset: str, spec: dict[str, Any] | None = None) -> int:
    from alcove.science.ocp.task_spec import parse_task, task_preset

    # a given spec is validated like the API's (TaskSpecError names the field) and stored normalised
    body = (parse_task(spec) if spec is not None else task_preset(preset)).model_dump(mode="json")
    return _find_or_create(s, owner_id, TASKS, preset, preset, body)


def oracle_version_for(s: Session, owner_id: int, oracle_type: str, params: dict[str, Any] | None = None) -> int:
    from alcove.oracles.service import command_catalogue
    from alcove.science.oracles.registry import BUILTIN_TYPE_NAMES, build_oracle

    catalogue = None if oracle_type in BUILTIN_TYPE_NAMES else command_catalogue(s)
    # validates; raises OracleInputError naming the field
    oracle = build_oracle(oracle_type, params or {}, catalogue=catalogue)
    body = oracle.params.model_dump(mode="json")
    return _find_or_create(s, owner_id, ORACLES, oracle_type, oracle_type, body, oracle_type=oracle_type)


def surrogate_config_version_for(s: Session, owner_id: int, config: dict[str, Any] | None = None) -> int:
    from alcove.science.surrogate.config import SurrogateConfig as ScienceConfig

    body = ScienceConfig.parse(config or {}).model_dump(mode="json")
    return _find_or_create(s, owner_id, SURROGATE_CONFIGS, "paper-default", "surrogate", body)
