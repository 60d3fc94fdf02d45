"""ArviZ reads a fit's chains and agrees with hbis on ESS and R-hat.

    hbis fit --data REC.csv --out FIT
    python examples/python/arviz_ess.py FIT

needs `pip install arviz`. Prints, per parameter, hbis's ESS and R-hat
(fit.json `sampling`) beside ArviZ's bulk ESS and R-hat on the CmdStan CSV
chains, and exits 1 when a ratio leaves [0.5, 2] or R-hat exceeds 1.01.
"""

import glob
import json
import os
import sys

import arviz as az


def main(folder: str) -> int:
    with open(os.path.join(folder, "fit.json")) as f:
        sampling = json.load(f)["sampling"]
    files = sorted(glob.glob(os.path.join(folder, "chains", "chain-*.csv")))
    if not files:
        print(f"{folder}: no chain files (was the fit run with --no-chains?)")
        return 1
    idata = az.from_cmdstan(files)
    names = list(sampling["ess"].keys())
    summary = az.summary(idata, var_names=names, kind="diagnostics")
    print(
        f"thin {sampling.get('thin')}, layout {sampling['chain_layout']}, "
        f"{len(files)} chains x {idata.posterior.sizes['draw']} draws"
    )
    ok = True
    for name in names:
        ess, bulk = sampling["ess"][name], summary.loc[name, "ess_bulk"]
        rhat = summary.loc[name, "r_hat"]
        ratio = bulk / ess
        ok &= 0.5 <= ratio <= 2.0 and rhat <= 1.01
        print(
            f"{name:8} hbis ESS {ess:8.0f}  ArviZ bulk ESS {bulk:8.0f}  "
            f"ratio {ratio:5.2f}  ArviZ R-hat {rhat:.3f}  hbis R-hat {sampling['rhat'][name]:.4f}"
        )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "hbis-fit"))
