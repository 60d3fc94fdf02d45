"""Ranking models fitted to one record by PSIS-LOO (ArviZ), beside BIC and
the Laplace log-evidence (docs/criticism.md, "Ranking by LOO").

    python examples/python/loo_compare.py

needs `pip install "./python[analysis]"`. Three records of
`trilinear+lcfm+viscous` (Table 8.1 columns 3, 5 and 6; 2,001 samples at
200 Hz; 1.5 % white noise; seeds 1-3), each fitted with the true
structure, a nested model without its third branch and friction slope
(`bilinear+coulomb+viscous`) and the true structure plus an unneeded
offset. Prints per record and model: elpd_loo (its se), p_loo, the
difference from the best and its se, BIC, log-evidence, convergence,
seconds, and how many samples have a Pareto k above 0.7 (the PSIS
estimate of their term is then unreliable).
"""

import time
import warnings

import arviz as az
import hbis

MODELS = ["trilinear+lcfm+viscous", "bilinear+coulomb+viscous", "trilinear+lcfm+viscous+offset"]


def main() -> None:
    warnings.simplefilter("ignore")  # az.compare's stacking overflows harmlessly
    for seed, column in ((1, 3), (2, 5), (3, 6)):
        rec = hbis.synthesize(MODELS[0], hbis.table_8_1(column), dt=0.005, n=2001,
                              noise=0.015, seed=seed)
        fits, rows = {}, []
        for m in MODELS:
            t = time.time()
            f = hbis.fit(rec, m, seed=seed, evidence=True)
            idata = f.to_arviz()
            k = az.loo(idata, pointwise=True).pareto_k.values
            fits[m] = idata
            r = f.report
            rows.append((m, r["bic"], r["log_evidence"], f.converged, time.time() - t,
                         int((k > 0.7).sum())))
        cmp = az.compare(fits)
        print(f"record {seed} (Table 8.1 column {column}):")
        for m, bic, ev, conv, dt, bad in rows:
            c = cmp.loc[m]
            print(f"  {m:32s} elpd_loo {c['elpd_loo']:8.1f} (se {c['se']:.1f})"
                  f" p_loo {c['p_loo']:5.1f} diff {c['elpd_diff']:7.1f} (se {c['dse']:4.1f})"
                  f"  BIC {bic:9.1f}  log-evidence {ev:8.1f}  converged {conv}"
                  f"  {dt:.0f} s  k>0.7: {bad}")


if __name__ == "__main__":
    main()
