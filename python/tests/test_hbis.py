"""The Python package against the Rust binary: same inputs and seed, same
numbers. The binary is `HBIS_BIN` (set by `.ci/run`), else the newest of
`target/{release,debug}/hbis` in this repository."""

import csv
import json
import os
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import hbis

ROOT = Path(__file__).resolve().parents[2]
MODEL = "trilinear+lcfm+viscous"
# A short, cheap posterior run that still converges on a 2-core machine.
QUICK = dict(ensembles=2, tau_multiple=20.0, max_steps=4000)
QUICK_ARGS = ["--ensembles", "2", "--tau-multiple", "20", "--max-steps", "4000"]


def _binary():
    env = os.environ.get("HBIS_BIN")
    if env:
        assert Path(env).is_file(), f"HBIS_BIN={env} does not exist"
        return env
    found = [p for p in (ROOT / "target/release/hbis", ROOT / "target/debug/hbis") if p.is_file()]
    if not found:
        pytest.skip("no hbis binary: set HBIS_BIN or run cargo build")
    return str(max(found, key=lambda p: p.stat().st_mtime))


def run(args, cwd):
    return subprocess.run([_binary(), *args], cwd=cwd, capture_output=True, text=True)


@pytest.fixture(scope="module")
def record():
    return hbis.synthesize(MODEL, hbis.table_8_1(5), dt=0.005, n=1201, noise=0.015, seed=11)


@pytest.fixture(scope="module")
def fitted(record):
    return hbis.fit(record, MODEL, seed=4, forces=(60.0, 10.0), source="rec.csv", **QUICK)


@pytest.fixture(scope="module")
def cli_fit(record, tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    record.to_csv(str(d / "rec.csv"))
    o = run(
        ["fit", "--data", "rec.csv", "--out", "out", "--seed", "4", "--released-force", "60",
         "--static-friction", "10", *QUICK_ARGS],
        d,
    )
    assert o.returncode == 0, o.stderr
    return d / "out"


def test_table_and_simulate_match_the_binary(tmp_path):
    p = hbis.table_8_1(5)
    (tmp_path / "p.json").write_text(json.dumps(p))
    o = run(["simulate", "--model", MODEL, "--params", "p.json", "--dt", "0.01",
             "--duration", "8", "--out", "s.csv"], tmp_path)
    assert o.returncode == 0, o.stderr
    with open(tmp_path / "s.csv") as f:
        rows = list(csv.DictReader(f))
    t, u, v, a = hbis.simulate(MODEL, p, 0.01, 8.0)
    assert len(t) == len(rows) == 801
    ref = {k: np.array([float(r[k]) for r in rows]) for k in ("t", "u", "v", "a")}
    # The binary prints shortest round-trip decimals: the motion is equal to
    # the bit. `a` is what a record holds (the sampler's grid recurrence),
    # the binary's `a` the closed form evaluated per sample: round-off apart.
    for key, arr in (("t", t), ("u", u), ("v", v)):
        np.testing.assert_array_equal(arr, ref[key], err_msg=key)
    np.testing.assert_allclose(a, ref["a"], rtol=0, atol=1e-12 * np.abs(ref["a"]).max())


def test_the_record_round_trips_through_csv(record, tmp_path):
    record.to_csv(str(tmp_path / "r.csv"))
    back = hbis.Record.read(str(tmp_path / "r.csv"))
    np.testing.assert_array_equal(back.t, record.t)
    np.testing.assert_array_equal(back.a, record.a)
    assert record.sigma > 0 and len(record) == 1201


def _without(d, keys):
    """`d` without the entries named `keys`, at any depth."""
    if isinstance(d, dict):
        return {k: _without(v, keys) for k, v in d.items() if k not in keys}
    if isinstance(d, list):
        return [_without(v, keys) for v in d]
    return d


def test_fit_gives_the_binarys_numbers(fitted, cli_fit):
    cli = json.loads((cli_fit / "fit.json").read_text())
    # One runner under both: fit.json key for key, but for the clock, the
    # chain files and the checkpoint (Python keeps the draws in memory).
    local = {"wall_time_s", "chains", "checkpoint"}
    assert _without(fitted.report, local) == _without(cli, local)
    assert fitted.map == cli["map"]
    assert fitted.report["posterior"] == cli["posterior"]
    assert fitted.report["sampling"]["ess"] == cli["sampling"]["ess"]
    assert fitted.report["physical"] == cli["physical"]
    assert fitted.identifiability["weakest"] == cli["weakest"]
    assert fitted.thin == cli["sampling"]["thin"]


def test_posterior_is_the_chain_files(fitted, cli_fit):
    assert fitted.converged
    chains, draws, dim = fitted.posterior.shape
    assert dim == len(fitted.names) == 9
    assert chains == fitted.report["sampling"]["ensembles"] == 2
    for c in range(chains):
        with open(cli_fit / "chains" / f"chain-{c + 1}.csv") as f:
            rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
        header, body = rows[0], np.array(rows[1:], dtype=float)
        # The parameters, then eq. 8.1 per draw (the fit was given forces).
        assert header[2:] == fitted.names + list(hbis.PHYSICAL)
        assert body.shape == (draws, 2 + dim + 6)
        np.testing.assert_array_equal(body[:, 2 : 2 + dim], fitted.posterior[c])
        np.testing.assert_array_equal(body[:, 2 + dim :], fitted.physical()[c])
        np.testing.assert_array_equal(body[:, 0], fitted.log_prob[c])


def test_physical_per_draw_is_eq_8_1_as_the_binary_converts_it(fitted, tmp_path):
    phys = fitted.physical()
    assert phys.shape == fitted.posterior.shape[:2] + (6,)
    c, i = 1, phys.shape[1] // 2
    (tmp_path / "p.json").write_text(json.dumps(dict(zip(fitted.names, fitted.posterior[c, i].tolist()))))
    o = run(["convert", "--model", MODEL, "--params", "p.json", "--released-force", "60",
             "--static-friction", "10", "--json"], tmp_path)
    assert o.returncode == 0, o.stderr
    ref = json.loads(o.stdout[: o.stdout.index("}") + 1])
    np.testing.assert_allclose(phys[c, i], [ref[k] for k in hbis.PHYSICAL], rtol=1e-12)


def test_summary_is_a_dataframe_with_the_reports_numbers(fitted):
    df = fitted.summary()
    assert list(df.index) == fitted.names
    for n in fitted.names:
        assert df.loc[n, "mean"] == fitted.report["posterior"][n]["mean"]
        assert df.loc[n, "rhat"] <= 1.01


def test_arviz_agrees_with_hbis_on_ess_and_rhat(fitted):
    az = pytest.importorskip("arviz")
    idata = fitted.to_arviz()
    assert dict(idata.posterior.sizes) == {"chain": 2, "draw": fitted.posterior.shape[1]}
    assert "k0" in idata.posterior and "lp" in idata.sample_stats
    s = az.summary(idata, var_names=fitted.names)
    for n in fitted.names:
        ratio = s.loc[n, "ess_bulk"] / fitted.report["sampling"]["ess"][n]
        assert 0.5 <= ratio <= 2.0, f"{n}: ArviZ bulk ESS / hbis ESS = {ratio:.2f}"
        assert s.loc[n, "r_hat"] <= 1.01, n


def test_progress_is_reported_and_the_gil_released(record):
    calls = []
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.01)

    th = threading.Thread(target=tick)
    th.start()
    try:
        f = hbis.fit(record, MODEL, seed=2, progress=lambda s, n, tau: calls.append((s, n, tau)), **QUICK)
    finally:
        stop.set()
        th.join()
    assert calls, "no progress reported"
    steps = [c[0] for c in calls]
    assert steps == sorted(steps) and steps[-1] == f.report["sampling"]["steps"]
    # The other thread kept running while the fit held no GIL.
    assert len(ticks) > 10


def test_map_only_fit_has_no_posterior(record):
    f = hbis.fit(record, MODEL, seed=1, map_only=True)
    assert f.posterior is None and f.converged is None
    assert list(f.map) == sorted(hbis.param_names(MODEL))
    with pytest.raises(ValueError, match="MAP-only"):
        f.summary()


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: hbis.simulate("trilinear+lcfm+magic", hbis.table_8_1(5), 0.01, 1.0), "magic"),
        (lambda: hbis.simulate(MODEL, {"u0": 0.1}, 0.01, 1.0), "`uy` is missing"),
        (lambda: hbis.simulate(MODEL, {**hbis.table_8_1(5), "k9": 1.0}, 0.01, 1.0), "`k9` is not a parameter"),
        (lambda: hbis.simulate(MODEL, hbis.table_8_1(5), -0.01, 1.0), "dt = -0.01"),
        (lambda: hbis.table_8_1(9), "expected a Solarino test of Table 8.1: 3, 5, 6, 7 or 8"),
        (lambda: hbis.Record([0.0, 0.1, 0.1, 0.3], [1.0, 0.5, 0.2, 0.1]), "increase"),
        (lambda: hbis.fit(hbis.synthesize(MODEL, hbis.table_8_1(5)), MODEL, thin=0), "thin = 0"),
        (lambda: hbis.fit(hbis.synthesize(MODEL, hbis.table_8_1(5)), MODEL, noise="pink"), "noise `pink`"),
        (lambda: hbis.fit(hbis.synthesize(MODEL, hbis.table_8_1(5)), MODEL, moves="jump"), "moves `jump`"),
    ],
)
def test_bad_input_is_a_value_error_naming_it(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_diagnose_and_ladder_dicts_are_the_binarys_files(tmp_path):
    """One runner under both front ends: the dicts are the JSON files, key
    for key and value for value."""
    syn = hbis.synthesize("bilinear+coulomb+viscous", _bilinear(), dt=0.01, n=301, noise=0.01, seed=3)
    syn.to_csv(str(tmp_path / "r.csv"))
    rec = hbis.Record.read(str(tmp_path / "r.csv"))
    o = run(["diagnose", "--data", "r.csv", "--model", "bilinear+coulomb+viscous", "--seed", "5",
             "--out", "d"], tmp_path)
    assert o.returncode == 0, o.stderr
    cli = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    py = hbis.diagnose(rec, "bilinear+coulomb+viscous", seed=5, source="r.csv")
    assert py == cli
    assert len(py["candidates"]) > 0 and py["data"]["source"] == "r.csv"
    o = run(["ladder", "--data", "r.csv", "--model", "bilinear+coulomb", "--seed", "5",
             "--max-steps", "1", "--out", "l"], tmp_path)
    assert o.returncode == 0, o.stderr
    cli = json.loads((tmp_path / "l" / "ladder.json").read_text())
    py = hbis.ladder(rec, "bilinear+coulomb", seed=5, max_steps=1, source="r.csv")
    assert py == cli
    assert py["model"] == "bilinear+coulomb" and len(py["steps"]) >= 1


def _bilinear():
    p = hbis.table_8_1(3)
    return {k: p[k] for k in hbis.param_names("bilinear+coulomb+viscous")}


def test_the_module_docstring_example_runs():
    import doctest

    r = doctest.testmod(hbis, verbose=False)
    assert r.attempted >= 3 and r.failed == 0


def test_a_study_from_a_process_pool_and_dask_equals_hbis_batch(tmp_path):
    import sys

    # Imported by name, so that the pool's processes can unpickle its functions.
    sys.path.insert(0, str(ROOT / "examples/python"))
    import study_pool as study

    manifest = study.make_study(tmp_path, n_records=4)
    pool_rows = study.with_process_pool(tmp_path)
    pytest.importorskip("dask")
    assert study.with_dask(tmp_path) == pool_rows
    o = run(["batch", "--manifest", str(manifest), "--out", str(tmp_path / "batch")], tmp_path)
    assert o.returncode == 0, o.stderr
    with open(tmp_path / "batch" / "summary.csv") as f:
        cli = [(r["record"], r["model"], int(r["seed"]), r["parameter"], float(r["map"])) for r in csv.DictReader(f)]
    assert cli == pool_rows
    assert len(cli) == 4 * 6


def test_the_uq_study_notebook_runs_and_its_output_holds(tmp_path):
    """examples/python/uq_study.py (quick sampler): every fit converged by
    ArviZ's R-hat, the table and the figure written, coverage printed."""
    import re
    import sys

    pytest.importorskip("matplotlib")
    o = subprocess.run([sys.executable, str(ROOT / "examples/python/uq_study.py"), "--quick", str(tmp_path)],
                       capture_output=True, text=True, cwd=tmp_path)
    assert o.returncode == 0, o.stderr
    m = re.search(r"covering the truth: (\d+) of 45", o.stdout)
    assert m, o.stdout
    # 45 intervals of nominal 90 %: were they independent, fewer than 33
    # covered would have probability below 1e-3 (the seeds are fixed).
    assert int(m.group(1)) >= 33, o.stdout
    rhat = float(re.search(r"largest R-hat ([0-9.]+)", o.stdout).group(1))
    assert rhat <= 1.01, o.stdout
    assert (tmp_path / "forest.png").stat().st_size > 10_000
    assert len((tmp_path / "summary.csv").read_text().splitlines()) == 1 + 45


def test_predict_gives_the_binarys_numbers(fitted, cli_fit, tmp_path):
    o = run(
        ["predict", "--fit", str(cli_fit), "--synthetic", "--seed", "5", "--pga", "2.0", "--draws", "200",
         "--tail", "10", "--capacity", "0.1", "--json", "--out", "pred"],
        tmp_path,
    )
    assert o.returncode == 0, o.stderr
    cli = json.loads(o.stdout)
    # The CLI's synthetic motion: Kanai-Tajimi, 40 s at 100 Hz, seed 5.
    t, ag = hbis.ground_motion(seed=5, pga=2.0)
    assert t[1] == pytest.approx(0.01) and np.max(np.abs(ag)) == pytest.approx(2.0)
    p = fitted.predict(ag, 0.01, draws=200, tail=10.0, capacity=0.1)
    for key in hbis.Prediction.COLUMNS + ["peak_base_shear_kn"]:
        for s in ["mean", "sd", "q05", "q50", "q95"]:
            assert p.summary[key][s] == pytest.approx(cli["summary"][key][s], rel=1e-12), (key, s)
    assert p.p_exceed_capacity == cli["p_exceed_capacity"]
    assert p.per_draw.shape == (200, 4)
    df = p.to_dataframe()
    assert list(df.columns) == hbis.Prediction.COLUMNS
    assert df["peak_displacement"].quantile(0.5) == pytest.approx(p.summary["peak_displacement"]["q50"])


def test_predict_one_parameter_set_and_bad_input(tmp_path):
    t, ag = hbis.ground_motion(seed=2, duration=10.0)
    p = hbis.predict(hbis.table_8_1(5), ag, 0.01, tail=5.0)
    d = p.summary["peak_displacement"]
    assert d["sd"] == 0.0 and d["q05"] == d["mean"] == d["q95"] > 0.0
    (tmp_path / "gm.csv").write_text("t,ag\n0,0.0\n0.01,0.1\n0.02,0.0\n")
    tt, a = hbis.read_motion(str(tmp_path / "gm.csv"), units="g")
    assert a[1] == pytest.approx(0.980665)
    with pytest.raises(ValueError, match="units='g'"):
        hbis.read_motion(str(tmp_path / "gm.csv"))
    with pytest.raises(ValueError, match="'u3' is missing"):
        hbis.predict({k: v for k, v in hbis.table_8_1(5).items() if k != "u3"}, ag, 0.01)
    with pytest.raises(ValueError, match="tail"):
        hbis.predict(hbis.table_8_1(5), ag, 0.01, tail=-1.0)


EFFECT = ROOT / "examples" / "effects" / "maxwell.toml"


def test_an_effect_file_fits_as_the_binary_fits_it(tmp_path):
    model = "trilinear+lcfm+viscous+maxwell-file"
    effects = [str(EFFECT)]
    with pytest.raises(ValueError, match="maxwell-file"):
        hbis.param_names(model)
    assert hbis.param_names(model, effects=effects)[-2:] == ["r_mf", "tau_mf"]
    p = dict(hbis.table_8_1(5), r_mf=0.15, tau_mf=0.4)
    syn = hbis.synthesize(model, p, dt=0.005, n=801, noise=0.015, seed=3, effects=effects)
    syn.to_csv(str(tmp_path / "r.csv"))
    o = run(["fit", "--data", "r.csv", "--model", model, "--effects", str(EFFECT), "--seed", "2",
             "--map-only", "--max-evals", "3000", "--out", "f"], tmp_path)
    assert o.returncode == 0, o.stderr
    cli = json.loads((tmp_path / "f" / "fit.json").read_text())
    py = hbis.fit(syn, model, seed=2, map_only=True, max_evals=3000, effects=effects)
    assert py.map == cli["map"]
    assert py.report["e2"] == cli["e2"]
    with pytest.raises(ValueError, match="effects: .*nope.toml"):
        hbis.simulate(model, p, 0.005, 1.0, effects=[str(tmp_path / "nope.toml")])
    with pytest.raises(ValueError, match="candidates: .*maxwel"):
        hbis.diagnose(syn, "trilinear+lcfm+viscous", candidates=["maxwel"])
