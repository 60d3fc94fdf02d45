"""The same study as `hbis batch`, from Python: with a process pool and
with Dask. Each item is `hbis.fit(record, model, seed=...)`, whose numbers
are the binary's, so all three give the same summary rows.

    python examples/python/study_pool.py [OUT_DIR]

writes OUT_DIR/records/*.csv and OUT_DIR/study.toml (the manifest
`hbis batch` reads), fits the study both ways and prints the tidy summary.
Needs `pip install "./python[analysis]" dask`.
"""

import multiprocessing
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import hbis

MODELS = ["bilinear+coulomb+viscous"]
SEEDS = [7]
OPTIONS = dict(map_only=True, max_evals=4000)
TESTS = [3, 5, 6, 7, 8]


def make_study(out: Path, n_records: int = 10) -> Path:
    """Synthetic records (Table 8.1 tests, 1.5 % noise) and their manifest."""
    (out / "records").mkdir(parents=True, exist_ok=True)
    lines = [f"models = {MODELS!r}".replace("'", '"'), f"seeds = {SEEDS!r}", "", "[fit]",
             "map-only = true", "max-evals = 4000"]
    for i in range(n_records):
        rec = hbis.synthesize("trilinear+lcfm+viscous", hbis.table_8_1(TESTS[i % 5]),
                              dt=0.01, n=401, noise=0.015, seed=i)
        rec.to_csv(str(out / "records" / f"rec{i:02d}.csv"))
        lines += ["", "[[record]]", f'path = "records/rec{i:02d}.csv"']
    (out / "study.toml").write_text("\n".join(lines) + "\n")
    return out / "study.toml"


def items(out: Path):
    """(record name, path, model, seed), in `hbis batch`'s order."""
    for path in sorted((out / "records").glob("*.csv")):
        for model in MODELS:
            for seed in SEEDS:
                yield path.stem, str(path), model, seed


def fit_item(item):
    """One item: the tidy rows `hbis batch` writes (MAP columns)."""
    name, path, model, seed = item
    fit = hbis.fit(hbis.Record.read(path), model, seed=seed, **OPTIONS)
    return [(name, model, seed, p, v) for p, v in sorted(fit.map.items())]


def with_process_pool(out: Path, workers: int = 2):
    # Each fit releases the GIL and uses Rayon's threads; processes also
    # isolate the items from each other. "spawn", not Linux's default
    # "fork": a process forked after a fit inherits a Rayon pool without
    # its threads and would wait for them forever.
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        return [row for rows in pool.map(fit_item, list(items(out))) for row in rows]


def with_dask(out: Path):
    import dask

    tasks = [dask.delayed(fit_item)(it) for it in items(out)]
    return [row for rows in dask.compute(*tasks, scheduler="processes") for row in rows]


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "hbis-study-py")
    manifest = make_study(out)
    pool_rows = with_process_pool(out)
    dask_rows = with_dask(out)
    assert pool_rows == dask_rows, "the two engines disagree"
    try:
        import pandas as pd

        df = pd.DataFrame(pool_rows, columns=["record", "model", "seed", "parameter", "map"])
        print(df.pivot(index="record", columns="parameter", values="map"))
    except ImportError:
        for r in pool_rows:
            print(*r, sep=",")
    print(f"same rows from a process pool and from Dask ({len(pool_rows)} rows); "
          f"the same study by the binary: hbis batch --manifest {manifest} --out {out / 'batch'}")


if __name__ == "__main__":
    main()
