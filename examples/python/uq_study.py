# %% [markdown]
# # An uncertainty-quantification study of the five Solarino tests
#
# Runnable as a script (`python examples/python/uq_study.py [--quick] [OUT]`)
# or cell by cell in a notebook (VS Code / Jupyter read the `# %%` marks).
# The paper's measured records are not distributed, so each test is a
# synthetic record made from its Table 8.1 parameters with 1.5 % noise; the
# truth is then known and every interval can be checked against it.
# Needs `pip install "./python[analysis]"` (numpy, pandas, ArviZ, matplotlib).

# %%
import sys
from pathlib import Path

import arviz as az
import matplotlib

matplotlib.use("Agg")  # files, not windows: runs headless too
import matplotlib.pyplot as plt
import pandas as pd

import hbis

QUICK = "--quick" in sys.argv  # a shorter sampler run, for CI
OUT = Path(next((a for a in sys.argv[1:] if not a.startswith("--")), "uq-study"))
OUT.mkdir(parents=True, exist_ok=True)
MODEL = "trilinear+lcfm+viscous"
TESTS = [3, 5, 6, 7, 8]
SAMPLER = dict(ensembles=2, tau_multiple=20.0, max_steps=4000) if QUICK else {}

# %% [markdown]
# ## Records and fits
# One record per test (seed = test number) and one fit per record (seed 1).

# %%
fits, truths = {}, {}
for k in TESTS:
    truth = hbis.table_8_1(k)
    rec = hbis.synthesize(MODEL, truth, dt=0.005, n=2001, noise=0.015, seed=k)
    fits[k] = hbis.fit(rec, MODEL, seed=1, **SAMPLER)
    truths[k] = truth
    print(f"Test {k}: {fits[k]}")

# %% [markdown]
# ## Posterior summary against the truth

# %%
rows = []
for k, fit in fits.items():
    s = fit.summary()
    for name in fit.names:
        t = truths[k][name]
        rows.append(dict(test=k, parameter=name, truth=t, mean=s.loc[name, "mean"], sd=s.loc[name, "sd"],
                         q05=s.loc[name, "q05"], q95=s.loc[name, "q95"], ess=s.loc[name, "ess"],
                         rhat=s.loc[name, "rhat"], covered=s.loc[name, "q05"] <= t <= s.loc[name, "q95"]))
table = pd.DataFrame(rows)
table.to_csv(OUT / "summary.csv", index=False)
with pd.option_context("display.width", 140, "display.max_rows", 60):
    print(table.to_string(index=False, float_format=lambda x: f"{x:.5g}"))
covered = int(table["covered"].sum())
print(f"90 % intervals covering the truth: {covered} of {len(table)} ({100 * covered / len(table):.0f} %)")
print("weakest parameter per test: " + ", ".join(f"Test {k}: {f.identifiability['weakest']}" for k, f in fits.items()))

# %% [markdown]
# ## ArviZ: diagnostics and a forest plot across the tests

# %%
idatas = {f"Test {k}": fit.to_arviz() for k, fit in fits.items()}
worst_rhat = max(float(az.rhat(d).to_array().max()) for d in idatas.values())
min_ess = min(float(az.ess(d).to_array().min()) for d in idatas.values())
print(f"ArviZ over all fits: largest R-hat {worst_rhat:.4f}, smallest bulk ESS {min_ess:.0f}")

axes = az.plot_forest(list(idatas.values()), model_names=list(idatas), var_names=["f0", "f1", "f2"],
                      combined=True, hdi_prob=0.9, figsize=(7, 5))
axes[0].set_title("Branch frequencies f0, f1, f2 (Hz), 90 % HDI per test")
plt.tight_layout()
plt.savefig(OUT / "forest.png", dpi=110)
print(f"wrote {OUT / 'summary.csv'} and {OUT / 'forest.png'}")
