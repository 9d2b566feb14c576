"""The API process imports neither torch nor casadi, even after serving requests that
validate tasks, oracles and campaigns and queue previews (checked in a fresh interpreter)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

SCRIPT = textwrap.dedent(
    """
    import json, sys, uuid
    from fastapi.testclient import TestClient
    from alcove.app import create_app
    from alcove.db import open_transaction
    from alcove.models import ApiToken, TokenKind, User

    with open_transaction() as s:
        user = User(email=f"light-{uuid.uuid4().hex[:8]}@example.org", role="member")
        s.add(user)
        token, secret = ApiToken.issue(user, kind=TokenKind.personal)
        s.add(token)
    client = TestClient(create_app())
    h = {"Authorization": f"Bearer {secret}"}
    codes = {}
    def call(name, method, url, **kw):
        r = client.request(method, "/api/v1" + url, headers=h, **kw)
        codes[name] = r.status_code
        return r.json() if r.headers.get("content-type", "").startswith("application/json") else None
    call("openapi", "GET", "/openapi.json")
    preset = call("presets", "GET", "/tasks/presets")[0]["spec"]
    call("check", "POST", "/tasks/check", json={"spec": preset})
    task = call("task", "POST", "/tasks", json={"name": "t", "spec": preset})
    call("types", "GET", "/oracles/types")
    oracle = call("oracle", "POST", "/oracles", json={"name": "o", "type": "aux-penalty"})
    camp = call("campaign", "POST", "/campaigns", json={"name": "c", "task_id": task["id"], "oracle_id": oracle["id"]})
    call("list", "GET", "/campaigns")
    call("metrics", "GET", f"/campaigns/{camp['id']}/metrics")
    preview = call("task preview", "POST", f"/tasks/{task['id']}/previews", json={"spec": preset, "intervals": 4})
    call("oracle preview", "POST", f"/oracles/{oracle['id']}/previews", json={"params": {}})
    call("preview", "GET", f"/previews/{preview['id']}")
    heavy = sorted(m for m in ("torch", "casadi") if m in sys.modules)
    print(json.dumps({"codes": codes, "heavy": heavy}))
    """
)


def test_api_serves_without_importing_torch_or_casadi(pg_url: str, tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ALCOVE_")}
    env.update(ALCOVE_DATABASE_URL=pg_url, ALCOVE_DATA_DIR=str(tmp_path))
    proc = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert all(200 <= c < 300 for c in out["codes"].values()), out
    assert out["heavy"] == [], f"the API process imported {out['heavy']}"
