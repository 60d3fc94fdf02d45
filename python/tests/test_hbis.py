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


def test_to_arviz_carries_the_pointwise_log_likelihood_and_loo_ranks_models(record, fitted):
    """`az.loo` and `az.compare` work on `to_arviz()`: one term per draw and
    sample, reproducible from the fit's seed, and on a record of
    `trilinear+lcfm+viscous` the nested `bilinear+coulomb+viscous` (no
    third branch, no friction slope) ranks below the true structure."""
    az = pytest.importorskip("arviz")
    idata = fitted.to_arviz()
    ll = idata.log_likelihood["a"]
    assert ll.shape == (2, fitted.posterior.shape[1], len(fitted._raw.observed))
    again = fitted._raw.log_likelihood(int(fitted.seed))
    assert np.array_equal(ll.values, again)
    assert np.array_equal(idata.observed_data["a"].values, fitted._raw.observed)
    assert "log_likelihood" not in fitted.to_arviz(log_likelihood=False).groups()
    small = hbis.fit(record, "bilinear+coulomb+viscous", seed=4, **QUICK)
    cmp = az.compare({"true": idata, "nested": small.to_arviz()})
    print(cmp[["elpd_loo", "p_loo", "elpd_diff", "dse"]])
    assert cmp.index[0] == "true"
    assert cmp.loc["nested", "elpd_diff"] > 4 * cmp.loc["nested", "dse"]


def test_an_unconverged_fit_warns_why_and_a_converged_one_does_not(record, fitted):
    """As `hbis fit` exits 3, `hbis.fit` warns when its sample did not
    converge, with the report's reason."""
    import warnings

    with pytest.warns(hbis.NotConvergedWarning, match="^the posterior sample did not converge: ") as w:
        short = hbis.fit(record, "bilinear+coulomb+viscous", seed=4, walkers=16, max_steps=200,
                         max_evals=3000)
    assert short.converged is False
    assert short.report["sampling"]["not_converged"] in str(w[0].message)
    assert fitted.converged
    with warnings.catch_warnings():
        warnings.simplefilter("error", hbis.NotConvergedWarning)
        hbis.fit(record, "bilinear+coulomb+viscous", seed=4, max_evals=3000, map_only=True)


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


def test_runs_in_a_thread_pool_give_the_sequential_results(record):
    """Each run works on a worker of the library's thread pool
    (`hbis::parallel`): runs started together share the workers and give
    what they give one after another."""
    from concurrent.futures import ThreadPoolExecutor

    def one(seed):
        return hbis.fit(record, MODEL, seed=seed, map_only=True).map

    alone = [one(s) for s in range(1, 5)]
    with ThreadPoolExecutor(4) as ex:
        together = list(ex.map(one, range(1, 5)))
    assert together == alone
    assert alone[0] != alone[1]  # the seeds matter, so the check can fail


def test_map_only_fit_has_no_posterior(record):
    f = hbis.fit(record, MODEL, seed=1, map_only=True)
    assert f.posterior is None and f.converged is None
    assert list(f.map) == hbis.param_names(MODEL)  # in `names` order (issue 38), not alphabetical
    with pytest.raises(ValueError, match="MAP-only"):
        f.summary()


def test_the_averaging_sensor_is_a_model_name():
    avg = MODEL + "+averaging"
    rec = hbis.synthesize(avg, hbis.table_8_1(5), dt=0.005, n=1201, noise=0.015, seed=12)
    mean = hbis.fit(rec, avg, seed=1, map_only=True)
    instant = hbis.fit(rec, MODEL, seed=1, map_only=True)
    assert mean.report["model"] == avg
    # The sensor acts: the same record fits otherwise without it.
    assert mean.report["e2"] != instant.report["e2"]


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


def test_a_suite_and_its_fragility_give_the_binarys_numbers(fitted, cli_fit, tmp_path):
    """Issue 38: ``Fit.predict_suite`` pairs the draws with the same seeded
    motions as ``hbis predict --motions`` and gives its fragility."""
    o = run(
        ["predict", "--fit", str(cli_fit), "--motions", "4", "--seed", "5", "--pga", "0.3g,0.6g", "--draws", "40",
         "--tail", "10", "--capacity", "0.1", "--json", "--out", "pred"],
        tmp_path,
    )
    assert o.returncode == 0, o.stderr
    cli = json.loads(o.stdout)
    p = fitted.predict_suite(4, pga=["0.3g", "0.6g"], capacity=0.1, draws=40, tail=10.0, seed=5)
    assert p.report["pairs"] == cli["pairs"] == 40
    assert p.pairs.shape == (40, 2) and list(p.pairs[5]) == [5, 1]
    for key in hbis.Prediction.COLUMNS:
        for s in ["mean", "sd", "q05", "q50", "q95"]:
            assert p.summary[key][s] == pytest.approx(cli["summary"][key][s], rel=1e-12), (key, s)
    assert len(p.fragility) == len(cli["fragility"]) == 2
    for mine, theirs in zip(p.fragility, cli["fragility"]):
        for k in ["pga_g", "p_exceed", "ci_low", "ci_high", "effective_pairs", "pairs"]:
            assert mine[k] == pytest.approx(theirs[k], rel=1e-12), k
    assert p.p_exceed_ci["high"] == pytest.approx(cli["p_exceed_ci"]["high"], rel=1e-12)
    # The motions themselves: ground_motions is the CLI's suite.
    t, ag = hbis.ground_motions(4, seed=5, pga=0.3 * hbis.G)[2]
    assert np.max(np.abs(ag)) == pytest.approx(0.3 * hbis.G) and t[1] == pytest.approx(0.01)
    # A list of (t, ag) motions, scaled to the first level, gives the same.
    same = fitted.predict_suite(hbis.ground_motions(4, seed=5), pga=["0.3g", "0.6g"], capacity=0.1, draws=40, tail=10.0)
    assert [f["p_exceed"] for f in same.fragility] == [f["p_exceed"] for f in p.fragility]
    with pytest.raises(ValueError, match="give capacity"):
        fitted.predict_suite(2, pga=[2.0, 3.0], draws=4)
    with pytest.raises(ValueError, match=r"pga\[1\]: 'fast'"):
        fitted.predict_suite(2, pga=[2.0, "fast"], capacity=0.1, draws=4)
    with pytest.raises(ValueError, match="1 to 10000"):
        fitted.predict_suite(0, draws=4)
    with pytest.raises(TypeError, match=r"motions\[0\]"):
        fitted.predict_suite([np.zeros(5)], draws=4)


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


def test_predict_takes_the_t_ag_that_ground_motion_and_read_motion_return(fitted, tmp_path):
    # Issue 38: `fit.predict(hbis.ground_motion(...))` failed (`predict`
    # wanted `ag, dt`). The (t, ag) pair gives the numbers of `ag, dt`, to
    # the bit, and the old form keeps working.
    p5 = hbis.table_8_1(5)
    motion = hbis.ground_motion(seed=5, pga=2.0, duration=10.0)
    t, ag = motion
    old = fitted.predict(ag, 0.01, draws=40, tail=5.0, capacity=0.1)
    new = fitted.predict(motion, draws=40, tail=5.0, capacity=0.1)
    np.testing.assert_array_equal(new.per_draw, old.per_draw)
    assert new.report == old.report
    assert fitted.predict(motion, 0.01, 40, 5.0).report == fitted.predict(ag, 0.01, 40, 5.0).report
    one = hbis.predict(p5, motion, tail=5.0)
    assert one.report == hbis.predict(p5, ag, 0.01, tail=5.0).report
    assert hbis.predict(p5, [list(t), list(ag)], model=MODEL, tail=5.0).report == one.report
    # read_motion's (t, ag), from two columns at 50 Hz.
    rows = "".join(f"{0.02 * i!r} {0.1 * float(np.sin(i / 7.0))!r}\n" for i in range(300))
    (tmp_path / "gm.txt").write_text("t ag\n" + rows)
    read = hbis.read_motion(str(tmp_path / "gm.txt"), units="g")
    assert hbis.predict(p5, read, tail=2.0).report == hbis.predict(p5, read[1], 0.02, tail=2.0).report
    # The step comes from t, which must be uniform; a dt that disagrees
    # with it, a missing dt and a model given in dt's place are named.
    bent = t.copy()
    bent[7] = 0.075
    with pytest.raises(ValueError, match=r"ag: t\[7\] = 0.075 s, expected 0.07 s .*uniformly sampled"):
        fitted.predict((bent, ag), draws=10)
    with pytest.raises(ValueError, match=r"ag: .*one t per sample, got 1000 times for 1001 samples"):
        hbis.predict(p5, (t[:-1], ag))
    with pytest.raises(ValueError, match=r"dt: 0.02 s, but the step of the \(t, ag\) motion is 0.01 s"):
        hbis.predict(p5, motion, 0.02)
    with pytest.raises(TypeError, match="dt: missing"):
        fitted.predict(ag, draws=10)
    with pytest.raises(TypeError, match="give model by keyword"):
        hbis.predict(p5, motion, MODEL)


def test_map_is_in_names_order(record):
    # Issue 38: `fit.map` was alphabetical (fit.json's order).
    fit = hbis.fit(record, MODEL, seed=4, map_only=True)
    assert list(fit.map) == fit.names
    assert list(fit.names) != sorted(fit.names)  # the test would not tell otherwise
    assert fit.map == fit.report["map"]


def test_the_namespace_is_the_public_api_only():
    # Issue 38: `hbis` exported `np`, `json`, `Any`, `Dict`. No public
    # submodule is allowed either: the compiled part is `hbis._hbis`.
    public = sorted(n for n in dir(hbis) if not n.startswith("_"))
    assert public == sorted(hbis.__all__)
    names = {}
    exec("from hbis import *", names)
    names.pop("__builtins__")
    assert sorted(names) == sorted(hbis.__all__)


def _documented(cls):
    """The names a class's docstring (or a base's) lists under Attributes."""
    import re

    names = set()
    for c in cls.__mro__:
        doc = c.__dict__.get("__doc__") or ""
        if "Attributes" in doc:
            for line in doc.split("Attributes", 1)[1].splitlines():
                m = re.match(r"^\s*([\w, ]+) :", line)
                if m:
                    names.update(n.strip() for n in m.group(1).split(","))
    return names


def test_every_public_name_has_a_docstring(record):
    # Issue 38: `Fit.identifiability` and `Fit.converged` had none. Every
    # function, class, method and property of `__all__` has a docstring;
    # every constant is described in the module's, and every public
    # attribute of a class or of its instances in the class's Attributes.
    import inspect

    def doc(obj):
        return (getattr(obj, "__doc__", None) or "").strip()

    missing = []
    assert doc(hbis)
    for name in hbis.__all__:
        obj = getattr(hbis, name)
        if not (callable(obj) or inspect.isclass(obj)):
            if f"``{name}``" not in hbis.__doc__:
                missing.append(name)
            continue
        if not doc(obj):
            missing.append(name)
        if not inspect.isclass(obj):
            continue
        for member in dir(obj):
            if member.startswith("_"):
                continue
            owner = next(c for c in obj.__mro__ if member in vars(c))
            if owner.__module__ == "builtins":
                continue  # e.g. a warning's `args`, documented by Python
            raw = inspect.getattr_static(obj, member)
            if isinstance(raw, (classmethod, staticmethod)):
                raw = raw.__func__
            if isinstance(raw, property) or inspect.isfunction(raw):
                if not doc(raw):
                    missing.append(f"{name}.{member}")
            elif member not in _documented(obj):
                missing.append(f"{name}.{member}")
    t, ag = hbis.ground_motion(seed=2, duration=5.0)
    instances = [
        record,
        hbis.Record(record.t, record.a),
        hbis.fit(record, MODEL, seed=4, map_only=True),
        hbis.predict(hbis.table_8_1(5), ag, 0.01, tail=2.0),
    ]
    for obj in instances:
        documented = _documented(type(obj))
        for member in vars(obj):
            if not member.startswith("_") and member not in documented:
                missing.append(f"{type(obj).__name__}().{member}")
    assert not missing, f"undocumented: {missing}"


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


# Bad input, sizes and interruption (issue 37): every case is a Python
# exception naming its argument, never an abort, a hang or a wrong result.


def _raised_in_a_child(code, cwd):
    """What `code` (one statement) raises in a fresh interpreter, as
    "Type: message", so that an abort cannot take the suite with it."""
    import sys

    script = (
        "import hbis, numpy as np\n"
        "MODEL = 'trilinear+lcfm+viscous'\n"
        "try:\n"
        f"    {code}\n"
        "except Exception as e:\n"
        "    print(f'{type(e).__name__}: {e}')\n"
        "else:\n"
        "    print('no error')\n"
    )
    o = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=cwd)
    assert o.returncode == 0, f"the interpreter died (exit {o.returncode}): {o.stderr[-2000:]}"
    return o.stdout.strip()


@pytest.mark.parametrize(
    "code, message",
    [
        # The binary's `simulate` limit, in its words.
        ("hbis.simulate(MODEL, hbis.table_8_1(5), 1e-12, 1e3)",
         r"ValueError: duration 1000 s at dt 0.000000000001 s makes 1.000e15 samples, more than the limit of 1e7: "
         r"use a larger dt or a shorter duration"),
        # The library's limit on a ground motion (MAX_SAMPLES).
        ("hbis.ground_motion(duration=1e13, dt=0.01)", r"ValueError: .*more than the 2000000 samples"),
        # A record may hold MAX_SAMPLES samples (the binary's record reader).
        ("hbis.synthesize(MODEL, hbis.table_8_1(5), n=10**15)",
         r"ValueError: `n` = 1000000000000000: more than the 2,000,000 samples a record may hold"),
        ("hbis.synthesize(MODEL, hbis.table_8_1(5), dt=1e308, n=100)",
         r"ValueError: `\(n - 1\) dt` = inf: the last sample's time must be a finite number"),
        # The binary's limit on the chains kept in memory, before the MAP.
        ("hbis.fit(hbis.synthesize(MODEL, hbis.table_8_1(5), n=201), walkers=10**9)",
         r"ValueError: walkers 1000000000 x ensembles 2 x max_steps 20000 would keep [0-9.]+ GiB of chains in memory, "
         r"more than the limit of 8 GiB"),
        ("hbis.fit(hbis.synthesize(MODEL, hbis.table_8_1(5), n=201), walkers=4)",
         r"ValueError: walkers 4: the model has 9 parameters and the stretch move needs at least 2 x 9 = 18 walkers per ensemble$"),
    ],
)
def test_huge_sizes_are_refused_as_the_binary_refuses_them(code, message, tmp_path):
    import re

    got = _raised_in_a_child(code, tmp_path)
    assert re.match(message, got), got


@pytest.mark.parametrize("npts", ["1000000000000000", "9000000000000000000"])
def test_an_at2_header_claiming_huge_npts_is_a_value_error(npts, tmp_path):
    path = tmp_path / "m.AT2"
    path.write_text(f"PEER\nevent\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS= {npts}, DT= .0100 SEC\n0.1 0.2 0.3\n")
    got = _raised_in_a_child(f"hbis.read_motion({str(path)!r})", tmp_path)
    assert got.startswith("ValueError: ") and "NPTS" in got, got


def test_the_record_size_limit_is_the_binary_readers(tmp_path):
    """`Record` and `fit` refuse more than MAX_SAMPLES (2,000,000) samples
    in the words of the binary's reader, before any work; MAX_SAMPLES
    samples are a record."""
    limit = 2_000_000
    t = np.arange(limit + 1) * 0.005
    a = np.sin(7.0 * t) * np.exp(-0.05 * t)
    words = (
        f"row {limit + 2}: the record has {limit + 1} samples, more than the limit of {limit} "
        r"\(MAX_SAMPLES: 10,000 s at 200 Hz\)"
    )
    with pytest.raises(ValueError, match=words):
        hbis.Record(t, a)
    with pytest.raises(ValueError, match=words):
        hbis.fit((t, a), map_only=True, max_evals=100)
    assert len(hbis.Record(t[:limit], a[:limit])) == limit
    # And the fewest samples after the release (MIN_SAMPLES).
    with pytest.raises(ValueError, match="19 samples, need at least 20"):
        hbis.Record(t[:19], a[:19], t0=0.0)


def test_a_progress_callbacks_exception_ends_the_run_and_is_raised():
    rec = hbis.synthesize(MODEL, hbis.table_8_1(5), dt=0.005, n=1201, noise=0.015, seed=11)
    calls = []

    class Stop(Exception):
        pass

    stop = Stop("enough")

    def progress(steps, target, tau):
        calls.append(steps)
        raise stop

    with pytest.raises(Stop) as e:
        hbis.fit(rec, MODEL, seed=2, progress=progress, **QUICK)
    # The original exception object, raised at the first call: the fit stopped there.
    assert e.value is stop and calls == [0]
    steps = []

    def on_step(k, model):
        steps.append(k)
        raise stop

    syn = hbis.synthesize("bilinear+coulomb+viscous", _bilinear(), dt=0.01, n=301, noise=0.01, seed=3)
    with pytest.raises(Stop):
        hbis.ladder(syn, "bilinear+coulomb", seed=5, max_steps=2, progress=on_step)
    assert steps == [0]


@pytest.mark.parametrize("call", [
    lambda rec: hbis.fit(rec, MODEL, progress=5, map_only=True),
    lambda rec: hbis.ladder(rec, "bilinear+coulomb", progress="steps"),
])
def test_a_progress_that_is_not_callable_is_a_type_error_naming_it(call):
    rec = hbis.synthesize(MODEL, hbis.table_8_1(5), dt=0.005, n=401, seed=1)
    t = time.monotonic()
    with pytest.raises(TypeError, match=r"^progress: expected a callable progress\(.*\) or None, got "):
        call(rec)
    # Refused before any work.
    assert time.monotonic() - t < 0.5


_INTERRUPTED = """
import signal, sys, time
# Python handles Ctrl-C only when it starts with SIGINT not ignored; a
# suite launched in the background by a shell without job control (`cmd &`
# in a script, `nohup`) passes SIGINT ignored down to this script, where
# the interrupt would then be ignored as Python documents. Handle it as an
# interactive session does.
signal.signal(signal.SIGINT, signal.default_int_handler)
import hbis
n, callback, job = int(sys.argv[1]), sys.argv[2] == "yes", sys.argv[3]
rec = hbis.synthesize("trilinear+lcfm+viscous", hbis.table_8_1(5), n=n, seed=11)
def progress(steps, target, tau):
    if steps == 0:
        print("sampling", flush=True)
if job == "predict":
    t, ag = hbis.ground_motion(seed=2, duration=60.0)
    p = hbis.table_8_1(5)
    theta = [p[k] for k in hbis.param_names("trilinear+lcfm+viscous")]
print("ready", flush=True)
try:
    if job == "fit":
        hbis.fit(rec, seed=4, tau_multiple=1000.0, progress=progress if callback else None)
    elif job == "diagnose":
        hbis.diagnose(rec, "bilinear+coulomb")
    else:
        hbis._hbis.predict("trilinear+lcfm+viscous", [theta] * 100_000, 0.01, ag)
except KeyboardInterrupt:
    print("interrupted", flush=True)
else:
    print("finished", flush=True)
# The abandoned run must stop computing, not finish unseen: the process's
# CPU time over the next second, once the run's loop has seen the cancel.
time.sleep(0.5)
cpu = time.process_time()
time.sleep(1.0)
print(f"cpu {time.process_time() - cpu:.3f}", flush=True)
"""


@pytest.mark.parametrize("phase, n, callback, job", [
    ("ready", 1_000_001, "no", "fit"),
    ("sampling", 20_001, "yes", "fit"),
    ("ready", 20_001, "no", "diagnose"),
    ("ready", 2_001, "no", "predict"),
])
def test_ctrl_c_raises_keyboard_interrupt_at_once_and_stops_the_run(phase, n, callback, job, tmp_path):
    """SIGINT during the MAP of a long record (no callback), during the
    sampler (with a progress callback), during a diagnosis and during a
    prediction: KeyboardInterrupt within a second, no output left behind,
    and the abandoned run stops computing (a run left going would use a
    whole core or more in the second measured)."""
    import signal
    import sys

    p = subprocess.Popen([sys.executable, "-c", _INTERRUPTED, str(n), callback, job], cwd=tmp_path,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        lines = []
        while phase not in lines:
            line = p.stdout.readline()
            assert line, f"the script ended early: {lines} {p.stderr.read()}"
            lines.append(line.strip())
        time.sleep(2.0 if phase == "ready" else 0.5)
        p.send_signal(signal.SIGINT)
        sent = time.monotonic()
        timer = threading.Timer(30.0, p.kill)
        timer.start()
        try:
            last = p.stdout.readline().strip()
            if last == "sampling":
                last = p.stdout.readline().strip()
        finally:
            timer.cancel()
        delay = time.monotonic() - sent
        assert last == "interrupted", (last, p.stderr.read())
        assert delay < 1.0, f"KeyboardInterrupt {delay:.2f} s after SIGINT"
        cpu = p.stdout.readline().strip()
        assert cpu.startswith("cpu "), (cpu, p.stderr.read())
        assert float(cpu[4:]) < 0.25, f"the abandoned {job} still computes: {cpu} s of CPU in 1 s"
        assert p.wait(timeout=30) == 0
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert list(tmp_path.iterdir()) == []


def test_physical_arguments_are_refused_naming_them():
    t, ag = hbis.ground_motion(seed=2, duration=10.0)
    p = hbis.table_8_1(5)
    for mass, shown in ((-5.0, "-5"), (0.0, "0"), (float("nan"), "NaN"), (float("inf"), "inf")):
        with pytest.raises(ValueError, match=f"^mass {shown}: expected a finite number > 0$"):
            hbis.predict(p, ag, 0.01, mass=mass)
    with pytest.raises(ValueError, match=r"^masses\[1\] -1: expected a finite number > 0"):
        hbis._hbis.predict(MODEL, [list(p.values())] * 2, 0.01, ag, masses=[1.0, -1.0])
    with pytest.raises(ValueError, match=r"^capacity -0.1: expected a finite number > 0$"):
        hbis.predict(p, ag, 0.01, capacity=-0.1)
    with pytest.raises(ValueError, match="pga must be > 0"):
        hbis.ground_motion(pga=-1.0)
    # A positive mass still gives the base shear in kN.
    kn = hbis.predict(p, ag, 0.01, mass=5.0).summary["peak_base_shear_kn"]["q50"]
    assert kn > 0.0


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda r: hbis.synthesize(MODEL, hbis.table_8_1(5), seed=-1), ValueError,
         "seed: expected a non-negative integer, got -1 (int)"),
        (lambda r: hbis.synthesize(MODEL, hbis.table_8_1(5), n=-1), ValueError,
         "n: expected a non-negative integer, got -1 (int)"),
        (lambda r: hbis.fit(r, walkers=-3), ValueError, "walkers: expected a non-negative integer, got -3 (int)"),
        (lambda r: hbis.fit(r, walkers=2.5), TypeError, "walkers: expected a non-negative integer, got 2.5 (float)"),
        (lambda r: hbis.fit(r, ensembles=-1), ValueError, "ensembles: expected a non-negative integer, got -1"),
        (lambda r: hbis.fit(r, max_steps=-1), ValueError, "max_steps: expected a non-negative integer, got -1"),
        (lambda r: hbis.fit(r, max_evals=-1), ValueError, "max_evals: expected a non-negative integer, got -1"),
        (lambda r: hbis.fit(r, thin=-2), ValueError, "thin: expected a non-negative integer, got -2"),
        (lambda r: hbis.fit(r, seed=2**64), ValueError,
         "seed: expected a whole number at most 18446744073709551615, got 18446744073709551616"),
        (lambda r: hbis.ladder(r, MODEL, max_steps=-1), ValueError, "max_steps: expected a non-negative integer"),
        (lambda r: hbis.diagnose(r, MODEL, seed=-7), ValueError, "seed: expected a non-negative integer, got -7"),
        (lambda r: hbis.table_8_1(-1), ValueError, "k: expected a non-negative integer, got -1"),
        (lambda r: hbis.ground_motion(seed=-1), ValueError, "seed: expected a non-negative integer, got -1"),
    ],
)
def test_a_bad_integer_names_its_argument(call, error, message):
    rec = hbis.synthesize(MODEL, hbis.table_8_1(5), dt=0.005, n=401, seed=1)
    with pytest.raises(error, match="^" + message.replace("(", r"\(").replace(")", r"\)")):
        call(rec)


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda: hbis.Record(np.zeros((3, 2)), np.zeros((3, 2))), ValueError,
         r"^t: expected a 1-D array, got shape \(3, 2\)"),
        (lambda: hbis.fit((np.arange(40.0), np.ones((40, 1)))), ValueError,
         r"^a: expected a 1-D array, got shape \(40, 1\)"),
        (lambda: hbis._hbis.diagnose(np.zeros(()), np.zeros(3), MODEL), ValueError,
         r"^t: expected a 1-D array, got shape \(\)"),
        (lambda: hbis.predict(hbis.table_8_1(5), np.zeros((5, 2)), 0.01), ValueError,
         r"^ag: expected a 1-D array, got shape \(5, 2\)"),
        (lambda: hbis._hbis.align([0.0, 1.0], np.zeros(2)), TypeError,
         r"^t: expected a 1-D numpy array of float64, got \[0.0, 1.0\] \(list\)"),
        (lambda: hbis._hbis.align(np.arange(30.0), np.arange(30)), TypeError,
         r"^a: expected an array of float64, got dtype int64"),
    ],
)
def test_a_bad_array_names_its_argument_and_shape(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_a_strided_array_is_read_as_it_is_seen():
    rec = hbis.synthesize(MODEL, hbis.table_8_1(5), dt=0.005, n=801, seed=1)
    t2 = np.repeat(rec.t, 2)[::2]
    a2 = np.stack([rec.a, rec.a], axis=1)[:, 0]
    assert not a2.flags["C_CONTIGUOUS"]
    aligned = hbis._hbis.align(t2, a2)
    np.testing.assert_array_equal(aligned[1], rec.aligned_a)


def test_seeded_random_records_at_the_boundary_are_aligned_or_refused_naming_the_place():
    """A property test at the binding's array boundary (seeded, numpy's
    generator; no extra dependency): records of random length, with one
    sample of `t` or `a` made non-finite or huge, a column cut short, or
    time reversed, either align or raise a one-line ValueError; a single
    non-finite sample is refused naming its row (header = row 1) and its
    column, as the binary names a file's."""
    seed = 20261128
    print(f"seed {seed}")
    rng = np.random.default_rng(seed)
    specials = [np.nan, np.inf, -np.inf]
    refused = 0
    for case in range(300):
        n = int(rng.integers(0, 400))
        t = np.arange(n) * 0.005
        a = -np.exp(-0.5 * t) * np.cos(2 * np.pi * 0.5 * t) + rng.normal(0, 0.01, n)
        kind = int(rng.integers(0, 6))
        where = int(rng.integers(0, n)) if n else 0
        column = None
        if kind == 1 and n:
            column, value = ("t", "a")[int(rng.integers(0, 2))], specials[int(rng.integers(0, 3))]
            (t if column == "t" else a)[where] = value
        elif kind == 2 and n:
            a[where] = 1e300
        elif kind == 3:
            a = a[: max(0, n - 1 - int(rng.integers(0, 3)))]
        elif kind == 4:
            t = t[::-1].copy()
        try:
            hbis._hbis.align(t, a)
        except ValueError as e:
            refused += 1
            msg = str(e)
            assert msg and "\n" not in msg, f"case {case}: {msg!r}"
            if column is not None:
                assert msg.startswith(f"row {where + 2}, column `{column}`: value "), f"case {case}: {msg}"
        else:
            assert column is None, f"case {case}: a non-finite `{column}` at row {where + 2} was accepted"
    # Both outcomes occur: the cases are not all refused for one reason.
    assert 0 < refused < 300, refused
