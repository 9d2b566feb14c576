"""Pool datasets, pool folders and the preliminary upload CSV: formats and clear errors."""

import io
import json

import numpy as np
import pytest

from alcove.science.series import ForceSeries, Trajectory
from alcove.science.surrogate.config import SurrogateConfig, SurrogateConfigError
from alcove.science.surrogate.dataset import (
    PoolDataError,
    PoolDataset,
    load_pool_dir,
    load_preliminary_csv,
    save_pool_dir,
)


def test_pool_folder_round_trip(tmp_path, smooth_pool):
    prelim = PoolDataset(
        "preliminary-00",
        np.arange(5.0),
        np.linspace(0.1, 0.2, 5),
        np.zeros(5),
        np.ones((5, 3)),
        np.zeros((5, 3)),
        "preliminary",
    )
    save_pool_dir([prelim, *smooth_pool[:3]], tmp_path)
    back = load_pool_dir(tmp_path)
    assert [ds.name for ds in back] == ["preliminary-00", "sim-000", "sim-001", "sim-002"]
    assert back[0].origin == "preliminary" and back[1].origin == "oracle"
    np.testing.assert_array_equal(back[1].force, smooth_pool[0].force)
    # hand-built pool, as `alcove ocp solve` / `alcove oracle run` write it: origins from the names
    (tmp_path / "pool.json").unlink()
    ds = smooth_pool[4]
    Trajectory(ds.t, ds.q, ds.qd, 0 * ds.q).to_csv(tmp_path / "run7.traj.csv")  # with tau columns
    ForceSeries(ds.t, ds.force, ds.moment).to_csv(tmp_path / "run7.forces.csv")
    back = {d.name: d for d in load_pool_dir(tmp_path)}
    assert back["preliminary-00"].origin == "preliminary" and back["run7"].origin == "oracle"


def test_pool_folder_errors(tmp_path, smooth_pool):
    with pytest.raises(PoolDataError, match="is not a directory"):
        load_pool_dir(tmp_path / "missing")
    with pytest.raises(PoolDataError, match=r"^pool: .* holds no NAME.traj.csv"):
        load_pool_dir(tmp_path)
    save_pool_dir(smooth_pool[:2], tmp_path)
    (tmp_path / "sim-001.forces.csv").unlink()
    with pytest.raises(PoolDataError, match=r"^sim-001.forces.csv: missing"):
        load_pool_dir(tmp_path)
    save_pool_dir(smooth_pool[:2], tmp_path)
    (tmp_path / "sim-001.forces.csv").write_text("t,fx,fy,fz,mx,my,mz\n0,1,2,3,4,5,6\n1,1,2,3,4,5,6\n")
    with pytest.raises(PoolDataError, match=r"^sim-001.t: the trajectory .* not on the same time grid"):
        load_pool_dir(tmp_path)
    (tmp_path / "sim-001.forces.csv").write_text("t,fx,fy,fz,mx,my\n0,1,2,3,4,5\n")
    with pytest.raises(PoolDataError, match=r"^sim-001.forces.csv:mz: missing column"):
        load_pool_dir(tmp_path)
    (tmp_path / "sim-001.forces.csv").unlink()
    (tmp_path / "sim-001.traj.csv").unlink()
    (tmp_path / "orphan.forces.csv").write_text("t,fx\n")
    with pytest.raises(PoolDataError, match=r"^orphan.forces.csv: forces file without"):
        load_pool_dir(tmp_path)
    (tmp_path / "orphan.forces.csv").unlink()
    (tmp_path / "pool.json").write_text(json.dumps({"sim-000": {"origin": "guess"}}))
    with pytest.raises(PoolDataError, match=r"^sim-000.origin: 'guess' is not one of"):
        load_pool_dir(tmp_path)


def test_dataset_validation():
    t, q = np.arange(4.0), np.zeros(4)
    ok = {"t": t, "q": q, "qd": q, "force": np.zeros((4, 3)), "moment": np.zeros((4, 3))}
    for change, match in [
        ({"name": "bad name!"}, "^name: 'bad name!' is not a valid"),
        ({"t": np.array([])}, "^d.t: must be a non-empty"),
        ({"force": np.zeros((3, 3))}, "^d.force: has shape"),
        ({"moment": np.zeros((4, 2))}, "^d.moment: must have 3 columns, got 2"),
        ({"qd": np.array([0, 0, np.nan, 0])}, r"^d.qd: non-finite value \(NaN or inf\) at row 3"),
        ({"t": np.array([0.0, 1.0, 1.0, 2.0])}, "^d.t: time must increase strictly"),
        ({"origin": "fe"}, "^d.origin: 'fe' is not one of"),
        ({"weight": -1.0}, "^d.weight: must be a finite number >= 0"),
    ]:
        kw = {"name": "d", **ok, **change}
        with pytest.raises(PoolDataError, match=match):
            PoolDataset(**kw)


def test_preliminary_upload_csv():
    text = "simulation,t,q_0,qd_0,fx,fy,fz,mx,my,mz\n" + "".join(
        f"{s},{k * 0.1},{0.1 + 0.01 * k},{0.5},{k},0,0,0,{-k},0\n" for s in ("a", "b") for k in range(3)
    )
    pool = load_preliminary_csv(io.StringIO(text))
    assert [ds.name for ds in pool] == ["a", "b"] and all(ds.origin == "upload" for ds in pool)
    np.testing.assert_allclose(pool[1].moment[:, 1], [0, -1, -2])
    # without simulation and t: independent samples, dealt into chunks
    rows = "q_0,qd_0,fx,fy,fz,mx,my,mz\n" + "".join(f"{0.1 + 0.001 * k},0,{k},0,0,0,0,0\n" for k in range(25))
    pool = load_preliminary_csv(io.StringIO(rows), origin="preliminary", chunks=10)
    assert len(pool) == 10 and sum(ds.n_samples for ds in pool) == 25
    assert pool[0].name == "preliminary-00" and np.array_equal(pool[0].t, [0.0, 1.0, 2.0])


def test_preliminary_upload_csv_with_carriage_returns():
    """Lines may end in \\r (old Mac), \\r\\n or \\n, mixed; a stray \\r ends a line as the csv module reads it."""
    lines = ["q_0,qd_0,fx,fy,fz,mx,my,mz"] + [f"{0.1 + 0.001 * k},0,{k},0,0,0,0,0" for k in range(4)]
    for end in ("\r", "\r\n"):
        pool = load_preliminary_csv(io.StringIO(end.join(lines) + end), chunks=2)
        assert sum(ds.n_samples for ds in pool) == 4
    with pytest.raises(PoolDataError, match=r"^q_0: missing"):
        load_preliminary_csv(io.StringIO("\u00ceqc\r\u00c5%\n"))


@pytest.mark.parametrize(
    "text, match",
    [
        ("", "^header: the file is empty"),
        ("q_0,qd_0\n" + "x" * 200_000 + "\n", "^file: not a CSV file the reader can parse: field larger"),
        ("q_0,qd_0,fx,fy,fz,mx,my,mz\n", "^rows: .* no data rows"),
        ("qd_0,fx,fy,fz,mx,my,mz\n0,1,2,3,4,5,6\n", "^q_0: missing"),
        ("q_0,fx,fy,fz,mx,my,mz\n0,1,2,3,4,5,6\n", "^qd_0: missing column"),
        ("q_0,qd_0,fx,fy,fz,mx,my\n0,0,1,2,3,4,5\n", "^mz: missing column"),
        ("q_0,qd_0,fx,fy,fz,mx,my,mz,extra\n0,0,1,2,3,4,5,6,7\n", "^extra: unknown column"),
        ("q_0,qd_0,fx,fy,fz,mx,my,mz\n0,0,1,2,3,4,five,6\n", "^my: not a number at data row 1: 'five'"),
        ("q_0,qd_0,fx,fy,fz,mx,my,mz\n0,0,1,2,3,4,inf,6\n", r"^my: non-finite value \(NaN or inf\) at data row 1"),
        ("q_0,qd_0,fx,fy,fz,mx,my,mz\n0,0,1,2,3\n", "^row 2: has 5 fields"),
        (
            "simulation,t,q_0,qd_0,fx,fy,fz,mx,my,mz\na,1,0,0,0,0,0,0,0,0\na,0,0,0,0,0,0,0,0,0\n",
            "^a.t: time must increase",
        ),
    ],
)
def test_preliminary_upload_csv_errors(text, match):
    with pytest.raises(PoolDataError, match=match):
        load_preliminary_csv(io.StringIO(text))


def test_config_errors_name_the_field(tmp_path):
    for data, match in [
        ({"force": {"hidden": [6, 0]}}, "^force.hidden.1: Input should be greater than or equal to 1"),
        ({"moment": {"activation": "relu", "hidden": [4]}}, "^moment.activation: Input should be"),
        ({"learning_rate": 0}, "^learning_rate: Input should be greater than 0"),
        ({"test_fraction": 1.0}, "^test_fraction: "),
        ({"bogus": 1}, "^bogus: Extra inputs are not permitted"),
    ]:
        with pytest.raises(SurrogateConfigError, match=match):
            SurrogateConfig.parse(data)
    f = tmp_path / "c.json"
    f.write_text('{"batch_size": 256, "force": {"hidden": [8, 8]}}')
    cfg = SurrogateConfig.from_json(f)
    assert cfg.batch_size == 256 and cfg.force.hidden == (8, 8) and cfg.moment.hidden == (6, 6, 6, 4)
    f.write_text("[1, 2]")
    with pytest.raises(SurrogateConfigError, match=r"^config: must be a JSON object"):
        SurrogateConfig.from_json(f)
    f.write_text("{oops")
    with pytest.raises(SurrogateConfigError, match=r"^config: not valid JSON"):
        SurrogateConfig.from_json(f)
    defaults = SurrogateConfig()
    assert (defaults.learning_rate, defaults.batch_size, defaults.patience) == (0.01, 1024, 6)
    assert (defaults.test_fraction, defaults.validation_fraction) == (0.3, 0.2)
