"""The complete alcove schema (SQLAlchemy 2.0 typed mappings).

Import models from here; ``Base.metadata`` is what Alembic compares against.
Alembic migrations in ``migrations/`` are the only way the schema changes.
"""

from alcove.models import guards as _guards  # noqa: F401  (registers the immutability guard)
from alcove.models.artifact_builds import ArtifactBuild, ArtifactBuildStatus
from alcove.models.base import (
    ITERATION_STEPS,
    NAMING_CONVENTION,
    Base,
    CampaignStatus,
    DatasetOrigin,
    IterationStatus,
    OracleRunStatus,
    Role,
    SharePermission,
    StepName,
    StepStatus,
    TokenKind,
    UTCDateTime,
    utcnow,
)
from alcove.models.campaigns import (
    Campaign,
    CampaignConfigVersion,
    CampaignEvent,
    Iteration,
    IterationCandidate,
    IterationStep,
)
from alcove.models.data import (
    Blob,
    Dataset,
    IterationMetrics,
    ModelVersion,
    OcpSolution,
    OracleRun,
    PoolVersion,
    PoolVersionMember,
    QuarantinedResult,
)
from alcove.models.definitions import (
    CommandOracle,
    OracleDefinition,
    OracleVersion,
    SurrogateConfigDefinition,
    SurrogateConfigVersion,
    TaskDefinition,
    TaskVersion,
    canonical_json,
    spec_hash,
)
from alcove.models.guards import ImmutableRowError
from alcove.models.limits import DEFAULT_JOB_LIMITS, JobLimits
from alcove.models.ops import JobOutbox, SmokeCheck, WorkerHeartbeat
from alcove.models.previews import Preview, PreviewKind, PreviewStatus
from alcove.models.users import ApiToken, Share, User, hash_password, hash_token, new_token_secret, verify_password
from alcove.models.validation import MotionStatus, SuiteStatus, ValidationMetrics, ValidationMotion, ValidationSuite

__all__ = [
    "DEFAULT_JOB_LIMITS",
    "ITERATION_STEPS",
    "NAMING_CONVENTION",
    "ApiToken",
    "ArtifactBuild",
    "ArtifactBuildStatus",
    "Base",
    "Blob",
    "Campaign",
    "CampaignConfigVersion",
    "CampaignEvent",
    "CampaignStatus",
    "CommandOracle",
    "Dataset",
    "DatasetOrigin",
    "ImmutableRowError",
    "Iteration",
    "IterationCandidate",
    "IterationMetrics",
    "IterationStatus",
    "IterationStep",
    "JobLimits",
    "JobOutbox",
    "ModelVersion",
    "MotionStatus",
    "OcpSolution",
    "OracleDefinition",
    "OracleRun",
    "OracleRunStatus",
    "OracleVersion",
    "PoolVersion",
    "PoolVersionMember",
    "Preview",
    "PreviewKind",
    "PreviewStatus",
    "QuarantinedResult",
    "Role",
    "Share",
    "SharePermission",
    "SmokeCheck",
    "StepName",
    "StepStatus",
    "SuiteStatus",
    "SurrogateConfigDefinition",
    "SurrogateConfigVersion",
    "TaskDefinition",
    "TaskVersion",
    "TokenKind",
    "UTCDateTime",
    "User",
    "ValidationMetrics",
    "ValidationMotion",
    "ValidationSuite",
    "WorkerHeartbeat",
    "canonical_json",
    "hash_password",
    "hash_token",
    "new_token_secret",
    "spec_hash",
    "utcnow",
    "verify_password",
]
