"""Routes of the job limits: your own (``/me/job-limits``), the members' defaults and each
user's own (administrators)."""

from __future__ import annotations

from fastapi import APIRouter

from alcove.api.deps import SessionDep
from alcove.api.params import ObjectId
from alcove.users import limits, service
from alcove.users.auth import AdminUser, CurrentUser
from alcove.users.schemas import JobLimitsOut, JobLimitsUpdate

router = APIRouter(tags=["job limits"])


@router.get("/me/job-limits", response_model=JobLimitsOut, operation_id="get_my_job_limits")
def get_my_job_limits(user: CurrentUser, session: SessionDep) -> JobLimitsOut:
    """The job limits that bind you: campaigns running at once and the size of a campaign,
    surrogate config or preview."""
    return limits.limits_of(session, user)


@router.get("/admin/job-limits", response_model=JobLimitsOut, operation_id="get_default_job_limits")
def get_default_job_limits(admin: AdminUser, session: SessionDep) -> JobLimitsOut:
    """The members' default job limits (a member without limits of their own has these)."""
    return limits.defaults(session)


@router.patch("/admin/job-limits", response_model=JobLimitsOut, operation_id="update_default_job_limits")
def update_default_job_limits(body: JobLimitsUpdate, admin: AdminUser, session: SessionDep) -> JobLimitsOut:
    """Change the members' defaults: a field left out keeps its value, null lifts the limit.
    Size limits apply to the next create, edit or start; work already running goes on. A raised
    running-campaigns limit starts waiting campaigns at a worker's next reconciler pass (2 s)."""
    out = limits.set_defaults(session, body)
    session.commit()
    return out


@router.get("/users/{user_id:integer}/job-limits", response_model=JobLimitsOut, operation_id="get_user_job_limits")
def get_user_job_limits(user_id: ObjectId, admin: AdminUser, session: SessionDep) -> JobLimitsOut:
    """The job limits that bind a user, and where they come from."""
    return limits.limits_of(session, service.get_user(session, user_id))


@router.patch("/users/{user_id:integer}/job-limits", response_model=JobLimitsOut, operation_id="update_user_job_limits")
def update_user_job_limits(
    user_id: ObjectId, body: JobLimitsUpdate, admin: AdminUser, session: SessionDep
) -> JobLimitsOut:
    """Give a user limits of their own: the limits that bound them until now, with the fields
    given changed (null lifts a limit). The defaults no longer apply to them. A raised
    running-campaigns limit starts waiting campaigns at a worker's next reconciler pass (2 s)."""
    out = limits.set_own(session, service.get_user(session, user_id), body)
    session.commit()
    return out


@router.delete("/users/{user_id:integer}/job-limits", response_model=JobLimitsOut, operation_id="reset_user_job_limits")
def reset_user_job_limits(user_id: ObjectId, admin: AdminUser, session: SessionDep) -> JobLimitsOut:
    """Drop a user's own limits: the members' defaults bind them again (an administrator: no
    limit). Returns the limits that bind them now."""
    out = limits.reset_own(session, service.get_user(session, user_id))
    session.commit()
    return out
