"""An iteration's whole OCP trajectory (every phase, on the OCP grid) on synthesized data:
the values are the stored solution's, the phases tile the task, the replayed part follows
the iteration's settings, 404s are clear, forks read their source's, answers carry ETags."""

from __future__ import annotations

import time

import numpy as np
import pytest

from tests.helpers import Account

API = "/api/v1"


@pytest.fixture(scope="module")
def campaign(owner: Account) -> int:
    from alcove.db import open_transaction
    from tests.synthetic import synthesize_campaign

    with open_transaction() as s:
        return synthesize_campaign(
            s, owner.id, iterations=2, name="api-trajectory", curve_samples=11, pool_samples=10, ocp_intervals=10
        ).id


def stored(cid: int, k: int):
    from alcove.campaigns import repository as repo
    from alcove.db import open_transaction
    from alcove.db.arrays import get_arrays
    from alcove.solving.repository import latest_of_iteration

    with open_transaction() as s:
        sol = latest_of_iteration(s, repo.get_iteration(s, cid, k).id)
        return (
            sol.solver_status,
            sol.success,
            sol.n_iterations,
            sol.cost,
            sol.wall_time_s,
            get_arrays(s, sol.trajectory_sha256),
        )


def test_the_whole_trajectory_is_the_stored_solution_with_both_phases(client, owner: Account, campaign: int) -> None:
    r = client.get(f"{API}/campaigns/{campaign}/iterations/2/trajectory", headers=owner.headers)
    assert r.status_code == 200, r.text
    body = r.json()
    status, success, n_it, cost, wall, a = stored(campaign, 2)
    # every node of the OCP grid, over the whole task (not only the replayed phase)
    np.testing.assert_array_equal(body["t"], a["t"])
    np.testing.assert_array_equal(np.array(body["q"]), a["q"])
    np.testing.assert_array_equal(np.array(body["qd"]), a["qd"])
    np.testing.assert_array_equal(np.array(body["tau"]), a["tau"])
    assert len(body["t"]) == 21 and body["t"][-1] == pytest.approx(2.0)
    # the phases tile [t0, t_end] of the grid; the preset has two phases of 1 s
    phases = body["phases"]
    assert [p["index"] for p in phases] == [0, 1] and all(p["name"] for p in phases)
    assert phases[0]["t_start"] == pytest.approx(body["t"][0]) and phases[-1]["t_end"] == pytest.approx(body["t"][-1])
    assert phases[0]["t_end"] == pytest.approx(phases[1]["t_start"])
    assert sum(p["duration"] for p in phases) == pytest.approx(body["duration"]) == pytest.approx(2.0)
    # the phase boundary is a grid node; the oracle replays phase 1 only (the default setting)
    assert min(abs(t - phases[0]["t_end"]) for t in body["t"]) < 1e-12
    assert body["replay_phases"] == 1 and [p["replayed"] for p in phases] == [True, False]
    assert body["replay_t_end"] == pytest.approx(phases[0]["t_end"])
    assert body["solver"] == {
        "status": status,
        "converged": success,
        "iterations": n_it,
        "cost": cost,
        "wall_time_s": wall,
        "attempt": 1,
        "initial_guess": "previous",
        "message": "",
    }


def test_an_iteration_without_an_ocp_solution_is_a_clear_404(
    client, owner: Account, other: Account, campaign: int
) -> None:
    for k in (0, 99):
        r = client.get(f"{API}/campaigns/{campaign}/iterations/{k}/trajectory", headers=owner.headers)
        assert (
            r.status_code == 404 and "no OCP solution" in r.json()["detail"] and f"iteration {k}" in r.json()["detail"]
        )
    r = client.get(
        f"{API}/campaigns/{campaign}/iterations/1/trajectory", headers=other.headers
    )  # others' campaigns do not exist
    assert r.status_code == 404 and "OCP" not in r.json()["detail"]
    assert client.get(f"{API}/campaigns/{campaign}/iterations/1/trajectory").status_code == 401
    assert client.get(f"{API}/campaigns/{campaign}/iterations/-1/trajectory", headers=owner.headers).status_code == 422


def test_a_new_attempt_changes_the_answer_and_a_failed_solve_is_shown_as_such(
    client, owner: Account, campaign: int
) -> None:
    from alcove.campaigns import repository as repo
    from alcove.db import open_transaction
    from alcove.db.arrays import put_arrays
    from alcove.models import OcpSolution
    from tests.synthetic import ocp_arrays

    url = f"{API}/campaigns/{campaign}/iterations/1/trajectory"
    first = client.get(url, headers=owner.headers)
    assert client.get(url, headers={**owner.headers, "If-None-Match": first.headers["ETag"]}).status_code == 304
    with open_transaction() as s:
        it = repo.get_iteration(s, campaign, 1)
        a = ocp_arrays(7, 10)
        s.add(
            OcpSolution(
                campaign_id=campaign,
                iteration_id=it.id,
                attempt=2,
                success=False,
                solver_status="Maximum_Iterations_Exceeded",
                n_iterations=3000,
                cost=None,
                wall_time_s=9.0,
                message="no converged solution after 1 initial guess(es)",
                stats={},
                trajectory_sha256=put_arrays(s, a),
            )
        )
    from alcove.campaigns.views.router import REVISION_TTL_S

    time.sleep(REVISION_TTL_S + 0.05)  # a process reuses the solution it found for this long
    again = client.get(url, headers={**owner.headers, "If-None-Match": first.headers["ETag"]})
    assert again.status_code == 200
    body = again.json()
    assert body["solver"]["attempt"] == 2 and body["solver"]["converged"] is False and body["solver"]["cost"] is None
    assert "no converged solution" in body["solver"]["message"]
    np.testing.assert_array_equal(np.array(body["q"]), a["q"])


def test_a_fork_reads_its_source_iterations(client, owner: Account, campaign: int) -> None:
    r = client.post(
        f"{API}/campaigns/{campaign}/fork",
        json={"iteration": 2, "name": "fork", "settings": {"replay_phases": 2}},
        headers=owner.headers,
    )
    assert r.status_code == 201, r.text
    fork = r.json()["id"]
    src = client.get(f"{API}/campaigns/{campaign}/iterations/2/trajectory", headers=owner.headers).json()
    got = client.get(f"{API}/campaigns/{fork}/iterations/2/trajectory", headers=owner.headers).json()
    # the source's solution, replayed as the source iteration's settings said (not the fork's)
    assert got["t"] == src["t"] and got["q"] == src["q"] and got["replay_phases"] == 1
    assert (
        client.get(f"{API}/campaigns/{fork}/iterations/3/trajectory", headers=owner.headers).status_code == 404
    )  # the fork's own, not run


def test_a_fork_of_a_fork_serves_the_inherited_iteration_to_whom_the_fork_is_shared(
    client, owner: Account, campaign: int
) -> None:
    from tests.helpers import make_account

    r = client.post(f"{API}/campaigns/{campaign}/fork", json={"iteration": 2, "name": "fork-1"}, headers=owner.headers)
    assert r.status_code == 201, r.text
    r = client.post(
        f"{API}/campaigns/{r.json()['id']}/fork", json={"iteration": 1, "name": "fork-2"}, headers=owner.headers
    )
    assert r.status_code == 201, r.text
    fork = r.json()["id"]
    src = client.get(f"{API}/campaigns/{campaign}/iterations/1/trajectory", headers=owner.headers)
    assert src.status_code == 200
    url = f"{API}/campaigns/{fork}/iterations/1/trajectory"
    got = client.get(url, headers=owner.headers)
    assert got.status_code == 200 and got.json()["t"] == src.json()["t"] and got.json()["q"] == src.json()["q"]
    assert client.get(url, headers={**owner.headers, "If-None-Match": got.headers["ETag"]}).status_code == 304
    viewer = make_account("member", "trajectory-fork-viewer")
    assert client.get(url, headers={**viewer.headers, "If-None-Match": got.headers["ETag"]}).status_code == 404
    r = client.post(
        f"{API}/shares",
        json={"object_type": "campaign", "object_id": fork, "email": viewer.email},
        headers=owner.headers,
    )
    assert r.status_code == 201, r.text
    # shared: the fork's iteration 1, held by the (unshared) source campaign
    assert client.get(url, headers=viewer.headers).json()["q"] == src.json()["q"]
    assert client.get(f"{API}/campaigns/{campaign}/iterations/1/trajectory", headers=viewer.headers).status_code == 404


def test_the_trajectory_is_a_304_with_its_etag_and_others_are_refused(
    client, owner: Account, other: Account, campaign: int
) -> None:
    url = f"{API}/campaigns/{campaign}/iterations/2/trajectory"
    first = client.get(url, headers=owner.headers)
    etag = first.headers["ETag"]
    again = client.get(url, headers={**owner.headers, "If-None-Match": etag})
    assert again.status_code == 304 and again.content == b"" and again.headers["ETag"] == etag
    assert client.get(url, headers={"If-None-Match": etag}).status_code == 401  # still authenticated
    refused = client.get(url, headers=other.headers)
    assert refused.status_code == 404
    r = client.get(url, headers={**other.headers, "If-None-Match": etag})  # and authorized, never a 304
    assert r.status_code == 404 and r.json() == refused.json()
    assert (
        client.get(
            f"{API}/campaigns/{campaign}/iterations/1/trajectory", headers={**owner.headers, "If-None-Match": etag}
        ).status_code
        == 200
    )


def test_a_running_iteration_is_a_404_until_its_ocp_solution_is_written(client, owner: Account, campaign: int) -> None:
    from alcove.db import open_transaction
    from alcove.db.arrays import put_arrays
    from alcove.models import Campaign, Iteration, OcpSolution
    from tests.synthetic import ocp_arrays

    with open_transaction() as s:
        c = s.get(Campaign, campaign)
        it = Iteration(campaign_id=campaign, index=3, config_version_id=c.config_versions[-1].id, status="running")
        s.add(it)
        s.flush()
        iteration_id = it.id
    url = f"{API}/campaigns/{campaign}/iterations/3/trajectory"
    for _ in range(2):
        r = client.get(url, headers=owner.headers)
        assert r.status_code == 404 and "no OCP solution for iteration 3" in r.json()["detail"]
    with open_transaction() as s:  # the OCP step writes its solution: served at once, not after a remembered 404
        a = ocp_arrays(3, 10)
        s.add(
            OcpSolution(
                campaign_id=campaign,
                iteration_id=iteration_id,
                attempt=1,
                initial_guess="previous",
                success=True,
                solver_status="Solve_Succeeded",
                n_iterations=30,
                cost=1.0,
                wall_time_s=2.0,
                stats={},
                trajectory_sha256=put_arrays(s, a),
            )
        )
    r = client.get(url, headers=owner.headers)
    assert r.status_code == 200, r.text
    np.testing.assert_array_equal(np.array(r.json()["q"]), a["q"])
