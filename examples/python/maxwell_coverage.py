"""Coverage of the 90 % intervals of `maxwell` (r_m, tau_m) over fresh records.

Records: Test 5 with r_m ~ U(0.05, 0.3), tau_m ~ U(0.1, 2) s, 1.5 % noise,
10 s at 200 Hz; each fitted with `hbis.fit` defaults (MAP, then the sampler).
Seeds are drawn from a commit hash, so they are new for every commit:

    python examples/python/maxwell_coverage.py $(git rev-parse HEAD) 10

Prints one JSON line per record.
"""
import json
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import hbis

MODEL = "trilinear+lcfm+viscous+maxwell"


def one(seed):
    rng = np.random.default_rng(seed)
    r_m = float(rng.uniform(0.05, 0.3))
    tau_m = float(rng.uniform(0.1, 2.0))
    p = dict(hbis.table_8_1(5), r_m=r_m, tau_m=tau_m)
    rec = hbis.synthesize(MODEL, p, dt=0.005, n=2001, noise=0.015, seed=seed)
    fit = hbis.fit(rec, MODEL, seed=seed)
    post = fit.report["posterior"]
    out = {"seed": seed, "r_m": r_m, "tau_m": tau_m, "converged": fit.converged}
    for n, v in (("r_m", r_m), ("tau_m", tau_m)):
        out[n + "_q05"] = post[n]["q05"]; out[n + "_q95"] = post[n]["q95"]
        out[n + "_covered"] = post[n]["q05"] <= v <= post[n]["q95"]
    return out


if __name__ == "__main__":
    commit = sys.argv[1]
    base = int(commit[:8], 16)
    seeds = [base + i for i in range(int(sys.argv[2]))]
    print("seeds from commit", commit, seeds, flush=True)
    with ProcessPoolExecutor(2) as ex:
        for r in ex.map(one, seeds):
            print(json.dumps(r), flush=True)
