"""Fault injection is a test-only mechanism: the public API refuses it, and a process
without the explicit testing setting refuses a fault plan."""

from __future__ import annotations

import subprocess
import sys

from tests.helpers import Account, small_task_spec, unique

API = "/api/v1"


def _campaign_body(client, who: Account, **extra: object) -> dict:
    task = client.post(f"{API}/tasks", json={"name": unique("t"), "spec": small_task_spec()}, headers=who.headers)
    oracles = client.get(f"{API}/oracles/presets", headers=who.headers).json()
    oracle = client.post(f"{API}/oracles/presets/{oracles[0]['key']}/copy", json={}, headers=who.headers)
    assert task.status_code == 201 and oracle.status_code == 201, (task.text, oracle.text)
    return {"name": unique("c"), "task_id": task.json()["id"], "oracle_id": oracle.json()["id"], **extra}


def test_the_api_refuses_fault_injection_in_a_campaigns_settings(client, owner: Account) -> None:
    faulty = {"fault_injection": {"train": {"sleep_s": 1e9}}}
    r = client.post(f"{API}/campaigns", json=_campaign_body(client, owner, settings=faulty), headers=owner.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "settings.fault_injection", r.text
    created = client.post(f"{API}/campaigns", json=_campaign_body(client, owner), headers=owner.headers)
    assert created.status_code == 201, created.text
    cid = created.json()["id"]
    assert "fault_injection" not in created.json()["config"]["settings"]
    edit = client.patch(f"{API}/campaigns/{cid}/config", json={"settings": faulty}, headers=owner.headers)
    assert edit.status_code == 422 and edit.json()["detail"][0]["field"] == "settings.fault_injection", edit.text
    fork = client.post(f"{API}/campaigns/{cid}/fork", json={"iteration": 0, "settings": faulty}, headers=owner.headers)
    assert fork.status_code == 422, fork.text
    schema = client.get(f"{API}/openapi.json", headers=owner.headers).text
    assert "fault_injection" not in schema


def test_a_process_without_the_testing_setting_refuses_a_fault_plan(tmp_path) -> None:
    plan = tmp_path / "plan.json"
    plan.write_text('{"campaigns": {"*": {"train": {"raise_attempts": 99}}}}')
    env = {"ALCOVE_DATA_DIR": str(tmp_path / "data"), "ALCOVE_FAULT_PLAN": str(plan), "PATH": "/usr/bin:/bin"}
    code = "from alcove.settings import get_settings; get_settings()"
    refused = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert refused.returncode != 0 and "ALCOVE_FAULT_PLAN" in refused.stderr and "ALCOVE_TESTING" in refused.stderr
    cli = subprocess.run(
        [sys.executable, "-m", "alcove_worker.cli.main", "db", "current"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert cli.returncode != 0 and "ALCOVE_FAULT_PLAN" in cli.stdout + cli.stderr
    allowed = subprocess.run(
        [sys.executable, "-c", code + "; print(get_settings().fault_plan)"],
        env={**env, "ALCOVE_TESTING": "true"},
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert allowed.returncode == 0 and str(plan) in allowed.stdout, allowed.stderr


def test_without_the_testing_setting_no_fault_is_ever_read(monkeypatch, tmp_path) -> None:
    """Even a plan file next to a production process is never read (fault_for answers None
    without looking), and injecting refuses."""
    import pytest

    from alcove.jobs import faults
    from alcove.settings import get_settings

    monkeypatch.delenv("ALCOVE_TESTING", raising=False)
    monkeypatch.delenv("ALCOVE_FAULT_PLAN", raising=False)
    get_settings.cache_clear()
    try:
        assert faults.fault_for(1, "train", 1) is None
        with pytest.raises(RuntimeError, match="test processes only"):
            faults.inject(1, {"train": {"sleep_s": 1}})
    finally:
        get_settings.cache_clear()


def test_an_injected_sleep_can_be_limited_to_the_first_attempts(monkeypatch) -> None:
    """``sleep_attempts``: the attempts up to it sleep, a later one (the re-run after a kill) does
    not; without it every attempt sleeps. (Sleeps counted, not timed.)"""
    import time

    from alcove.jobs.faults import StepFault
    from alcove.jobs.step_contract import StepRun

    naps: list[float] = []
    monkeypatch.setattr(time, "sleep", naps.append)  # returns at once: the sleep loop spins until sleep_s passed

    def sleeps(attempt: int, **fault: float) -> bool:
        naps.clear()
        StepRun(attempt=attempt, fault=StepFault(sleep_s=0.05, **fault)).before_compute("train")
        return bool(naps)

    assert sleeps(1, sleep_attempts=1) and sleeps(2, sleep_attempts=2)
    assert not sleeps(2, sleep_attempts=1) and not sleeps(3, sleep_attempts=2)
    assert sleeps(1) and sleeps(5)
