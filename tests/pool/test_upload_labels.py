"""An upload makes one data set per distinct ``simulation`` label: the labels per upload are
capped (a 422 naming the field and the limit), and rows are grouped by label in one pass."""

from __future__ import annotations

import io

from tests.helpers import Account

from .test_upload_ranges import HEADER, upload


def labelled(labels: int, rows_per_label: int = 2) -> bytes:
    """Rows of ``labels`` simulations, interleaved (label i's rows are ``labels`` rows apart)."""
    body = "".join(f"s{i},{k * 0.01},0.2,0.5,10.0,0,1,0.1,0,0\n" for k in range(rows_per_label) for i in range(labels))
    return (HEADER + body).encode()


def field_error(r) -> tuple[str, str]:
    assert r.status_code == 422, (r.status_code, r.text[:500])
    item = r.json()["detail"][0]
    return item["field"], item["msg"]


def test_an_upload_of_4000_simulation_labels_is_refused_naming_the_field_and_the_limit(client, owner: Account) -> None:
    from alcove.pool.service import MAX_UPLOAD_SIMULATIONS

    field, msg = field_error(upload(client, owner, labelled(4000), name="many"))
    assert field == "file.simulation", msg
    assert "4000" in msg and str(MAX_UPLOAD_SIMULATIONS) in msg, msg


def test_an_upload_at_the_limit_is_stored_one_data_set_per_label(client, owner: Account) -> None:
    from alcove.pool.service import MAX_UPLOAD_SIMULATIONS

    r = upload(client, owner, labelled(MAX_UPLOAD_SIMULATIONS), name="limit")
    assert r.status_code == 201, r.text[:500]
    datasets = r.json()["datasets"]
    assert len(datasets) == MAX_UPLOAD_SIMULATIONS
    assert [d["name"] for d in datasets[:3]] == ["limit-s0", "limit-s1", "limit-s2"]
    assert {d["n_samples"] for d in datasets} == {2}


def test_rows_are_grouped_by_label_in_the_order_of_the_file() -> None:
    from alcove.science.surrogate.dataset import load_preliminary_csv

    text = HEADER + "".join(
        f"{lab},{t},{q},0.5,10.0,0,1,0.1,0,0\n"
        for t, lab, q in [(0.0, "b", 0.1), (0.0, "a", 0.2), (0.1, "b", 0.3), (0.2, "b", 0.4), (0.1, "a", 0.5)]
    )
    pool = load_preliminary_csv(io.StringIO(text), prefix="x")
    assert [(d.name, d.t.tolist(), d.q[:, 0].tolist()) for d in pool] == [
        ("x-b", [0.0, 0.1, 0.2], [0.1, 0.3, 0.4]),
        ("x-a", [0.0, 0.1], [0.2, 0.5]),
    ]


def test_a_header_with_many_columns_is_refused_naming_a_column(client, owner: Account) -> None:
    header = HEADER.strip() + "," + ",".join(f"extra_{i}" for i in range(20000)) + "\n"
    field, msg = field_error(upload(client, owner, (header + "s0" + ",0" * 20009 + "\n").encode()))
    assert field == "file.extra_0" and "unknown column" in msg
