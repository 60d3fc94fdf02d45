"""hbis: Bayesian identification of hybrid base isolation systems.

The same Rust library as the ``hbis`` command-line tool, with numpy arrays
in and out. Same inputs and seed give the numbers the binary gives.

>>> import hbis
>>> p = hbis.table_8_1(5)
>>> t, u, v, a = hbis.simulate("trilinear+lcfm+viscous", p, dt=0.005, duration=10.0)
>>> round(float(u[0]), 4) == p["u0"]
True

Errors in the inputs raise ``ValueError`` (``TypeError`` for a wrong type)
with the message the binary prints, naming the argument and what was
expected; sizes the binary refuses (a record of more than 2,000,000
samples, a simulated grid of more than 1e7) are refused before anything is
allocated. Long runs release the GIL and raise ``KeyboardInterrupt`` on
Ctrl-C at once; an exception raised by a ``progress`` callback ends the
run and is raised from the call.

The public API is ``__all__``: its functions and classes and the
constants ``DEFAULT_MODEL`` (the default model, ``hbis fit``'s),
``PHYSICAL`` (the names of eq. 8.1's quantities, in the order of
:meth:`Fit.physical`), ``PHYSICAL_UNITS`` (their units, Table 8.2's) and
``G`` (standard gravity, 9.80665 m/s^2, the ``g`` of a PGA ``"0.3g"``).
A motion for :func:`predict` and :meth:`Fit.predict` is the ``(t, ag)``
that :func:`ground_motion` and :func:`read_motion` return, or ``ag, dt``;
:meth:`Fit.predict_suite` takes a suite of them (:func:`ground_motions`)
and gives a fragility curve.
"""

# Helper imports under private names: the namespace is the public API
# (`__all__`) and nothing else.
import json as _json
import typing as _t
import warnings as _warnings

import numpy as _np

from . import _hbis

__version__ = _hbis.__version__

#: The quantities of eq. 8.1 per draw, in Table 8.2's units.
PHYSICAL = ("m", "k0", "k1", "k2", "kF", "c")
PHYSICAL_UNITS = ("t", "kN/m", "kN/m", "kN/m", "kN/m", "kN s/m")

#: The default model: tri-linear spring, linear-Coulomb friction, viscous damper.
DEFAULT_MODEL = "trilinear+lcfm+viscous"

#: Standard gravity (m/s^2): the ``g`` of a PGA given as ``"0.3g"``.
G = 9.80665


def table_8_1(k: int) -> dict[str, float]:
    """The identified parameters of Solarino test ``k`` (3, 5, 6, 7 or 8), Table 8.1, SI units."""
    return _hbis.table_8_1(int(k))


def _effects(effects: _t.Sequence[str]) -> list[str]:
    if isinstance(effects, (str, bytes)):
        effects = [effects]
    return [str(e) for e in effects]


def param_names(model: str = DEFAULT_MODEL, *, effects: _t.Sequence[str] = ()) -> list[str]:
    """The parameter names of ``model`` in their order (noise parameters
    excluded). ``effects``: effect files (TOML) whose components ``model``
    may name, as the binary's ``--effects`` (docs/components.md)."""
    return _hbis.param_names(model, effects=_effects(effects))


def simulate(
    model: str, params: dict[str, float], dt: float, duration: float, *, effects: _t.Sequence[str] = ()
) -> tuple[_np.ndarray, _np.ndarray, _np.ndarray, _np.ndarray]:
    """Free vibration after release: arrays ``(t, u, v, a)`` at ``t_i = i dt``.

    ``params`` maps every parameter of ``model`` (see :func:`param_names`)
    to its value in SI units; an unknown or missing name is a ``ValueError``.
    ``a`` is what an accelerometer records (output components included).
    ``effects``: effect files whose components ``model`` may name.
    """
    return _hbis.simulate(model, dict(params), float(dt), float(duration), effects=_effects(effects))


class Record:
    """A measured (or synthetic) release-test record: time ``t`` (s) and
    acceleration ``a`` (m/s^2), checked as the binary checks a file.

    Attributes
    ----------
    t, a : numpy.ndarray
        The record as given: time (s) and acceleration (m/s^2).
    t0 : float or None
        The release time given (``None``: detected).
    source : str
        The record's name in the reports (``data.source``): the file
        :meth:`read` read, else ``"array"``.
    aligned_t, aligned_a : numpy.ndarray
        The record from the release on, as the fit sees it.
    release : float
        The release time (s, the record's clock).
    release_source : str
        ``"given"`` (``t0``) or ``"detected"``.
    """

    def __init__(self, t: _t.Sequence[float], a: _t.Sequence[float], t0: _t.Optional[float] = None):
        self.t = _np.ascontiguousarray(t, dtype=float)
        self.a = _np.ascontiguousarray(a, dtype=float)
        self.t0 = t0
        # What the reports name it (`data.source`): the file it was read
        # from, as the binary names its --data.
        self.source = "array"
        # Checked now, so a bad record fails where it is made.
        self.aligned_t, self.aligned_a, self.release, self.release_source = _hbis.align(
            self.t, self.a, t0
        )

    @classmethod
    def read(cls, path: str, units: str = "m/s2", t0: _t.Optional[float] = None) -> "Record":
        """Reads a record file as ``hbis fit --data`` does (CSV with columns
        ``t`` and ``a``, or whitespace-separated text), converting the
        acceleration from ``units`` (``m/s2``, ``g``, ``mm/s2``) to m/s^2."""
        t, a = _hbis.read_record(str(path), units)
        record = cls(t, a, t0)
        record.source = str(path)
        return record

    def to_csv(self, path: str) -> None:
        """Writes the record as the ``t,a`` CSV the binary reads."""
        with open(path, "w") as f:
            f.write("t,a\n")
            for ti, ai in zip(self.t, self.a):
                f.write(f"{float(ti)!r},{float(ai)!r}\n")

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        return f"Record({len(self)} samples, release at t0 = {self.release:g} s, {self.release_source})"


class Synthetic(Record):
    """A synthetic record with the truth it was made from (a :class:`Record`).

    Attributes
    ----------
    clean : numpy.ndarray
        The acceleration without noise (m/s^2).
    sigma : float
        The noise's standard deviation (m/s^2).
    model : str
        The model it was made with.
    truth : dict
        The parameters it was made with, by name.
    """

    def __init__(self, t, a, clean, sigma, model, params):
        super().__init__(t, a)
        self.clean = clean
        self.sigma = sigma
        self.model = model
        self.truth = dict(params)


def synthesize(
    model: str,
    params: dict[str, float],
    dt: float = 0.005,
    n: int = 2001,
    noise: float = 0.015,
    seed: int = 1,
    *,
    effects: _t.Sequence[str] = (),
) -> Synthetic:
    """``model`` with ``params`` sampled ``n`` times at ``dt`` plus white
    Gaussian noise of ``noise`` times the peak |a| (seeded, as the binary's
    ``hbis synthesize``). ``effects``: effect files whose components
    ``model`` may name."""
    t, a, clean, sigma = _hbis.synthesize(
        model, dict(params), float(dt), int(n), float(noise), int(seed), effects=_effects(effects)
    )
    return Synthetic(t, a, clean, sigma, model, params)


class Fit:
    """A fitted record.

    Attributes
    ----------
    report : dict
        What ``fit.json`` holds (the binary's keys, documented in docs/cli.md).
    map : dict
        The MAP estimate by parameter name, in the order of :attr:`names`.
    names : list of str
        Parameter names, in the order of the last axis of :attr:`posterior`.
    posterior : numpy.ndarray or None
        Kept draws ``(chain, draw, param)``: one chain per ensemble, draws
        walker-major and thinned as the chain files (``report["sampling"]["thin"]``).
    log_prob : numpy.ndarray or None
        Log-posterior of each draw, ``(chain, draw)``.
    identifiability : dict or None
        Ranking, weakest parameter, its explanation and the per-parameter table.
    converged : bool or None
        Whether the sampler met its stopping rule; ``None`` for a MAP-only fit.
    seed : int
        The seed the fit was run with.
    effects : list of str
        The effect files the fit was given (used again by :meth:`predict`).
    thin : int
        The thinning of :attr:`posterior`: one kept draw every ``thin`` steps.
    """

    def __init__(self, raw: _t.Any, seed: int, effects: _t.Sequence[str] = ()):
        self._raw = raw
        self.seed = seed
        self.effects: list[str] = list(effects)
        self.names: list[str] = list(raw.names)
        self.report: dict[str, _t.Any] = _json.loads(raw.report_json)
        # In `names` order (fit.json's `map` is alphabetical); a key that is
        # not a parameter name, if any, after them in the report's order.
        m = self.report["map"]
        self.map: dict[str, float] = {n: m[n] for n in self.names if n in m}
        self.map.update((k, v) for k, v in m.items() if k not in self.map)
        self.posterior: _t.Optional[_np.ndarray] = raw.draws
        lp = raw.log_prob
        self.log_prob: _t.Optional[_np.ndarray] = None if lp is None else lp[:, :, 0]
        self.thin: int = raw.thin

    @property
    def identifiability(self) -> _t.Optional[dict[str, _t.Any]]:
        """What the fit says about which parameters the record pins down:
        ``ranking`` (parameters from best to worst identified), ``weakest``,
        ``explanation`` (the weakest one's case in words) and the report's
        per-parameter and design tables (``fit.json``'s ``ranking``,
        ``weakest``, ``explanation`` and ``identifiability``). ``None`` for a
        MAP-only fit."""
        r = self.report
        if r.get("ranking") is None:
            return None
        return {
            "ranking": r["ranking"],
            "weakest": r["weakest"],
            "explanation": r["explanation"],
            **(r.get("identifiability") or {}),
        }

    @property
    def converged(self) -> _t.Optional[bool]:
        """Whether the sampler met its stopping rule (``fit.json``'s
        ``sampling.converged``: the kept chain ``tau_multiple``
        autocorrelation times long, or the ``ess`` reached, and split R-hat
        <= 1.01 on every parameter; ``report["sampling"]["not_converged"]``
        says why not). ``None`` for a MAP-only fit, which has no sampling."""
        s = self.report.get("sampling")
        return None if s is None else bool(s["converged"])

    def physical(self) -> _np.ndarray:
        """Eq. 8.1 per draw: ``(chain, draw, 6)`` of ``m, k0, k1, k2, kF, c``
        (Table 8.2 units). Needs ``forces=(F0n, FfS)`` in :func:`fit`."""
        p = self._raw.physical
        if p is None:
            raise ValueError(
                "physical(): the fit has no forces; pass forces=(released_force_kN, static_friction_kN) to hbis.fit"
            )
        return p

    def summary(self):
        """Posterior summary per parameter (mean, sd, quantiles, ESS, R-hat):
        a pandas DataFrame when pandas is installed, else a dict of dicts."""
        post = self.report.get("posterior")
        if post is None:
            raise ValueError("summary(): a MAP-only fit has no posterior")
        s = self.report["sampling"]
        rows = {}
        for n in self.names:
            row = dict(post[n])
            row["map"] = self.map.get(n)
            row["ess"] = s["ess"][n]
            row["rhat"] = s["rhat"][n]
            row["tau"] = s["tau"][n]
            rows[n] = row
        try:
            import pandas as pd
        except ImportError:
            return rows
        return pd.DataFrame.from_dict(rows, orient="index")

    def to_arviz(self, log_likelihood: bool = True):
        """The draws as ArviZ ``InferenceData``: group ``posterior`` with dims
        ``(chain, draw)`` per parameter, ``sample_stats.lp``, (with forces)
        eq. 8.1's quantities as further posterior variables, and, unless
        ``log_likelihood=False``, groups ``log_likelihood`` (variable ``a``,
        dims ``(chain, draw, sample)``) and ``observed_data`` (the record as
        fitted), so that ``az.loo`` and ``az.compare`` rank models fitted to
        one record.

        The pointwise terms are Gaussian densities of each sample at the
        draw and a noise scale drawn from its conditional posterior (the fit
        integrates it out), from the fit's seed; for ``noise="ar1"`` they
        are one-step-ahead terms (``docs/criticism.md``). They take
        ``draws x samples x 8`` bytes (212 MB for a default fit of a
        2,001-sample record: 2 chains of 6,624 draws)."""
        import arviz as az

        if self.posterior is None:
            raise ValueError("to_arviz(): a MAP-only fit has no posterior")
        post = {n: self.posterior[:, :, k] for k, n in enumerate(self.names)}
        if self._raw.physical is not None:
            phys = self._raw.physical
            for k, n in enumerate(PHYSICAL):
                post[n] = phys[:, :, k]
        extra = {}
        if log_likelihood:
            extra = dict(
                log_likelihood={"a": self._raw.log_likelihood(int(self.seed))},
                observed_data={"a": self._raw.observed},
                dims={"a": ["sample"]},
            )
        return az.from_dict(
            **extra,
            posterior=post,
            sample_stats={"lp": self.log_prob},
            attrs={
                "model": self.report["model"],
                "seed": self.seed,
                "chain_layout": "one chain per ensemble, walker-major draws",
                "thin": self.thin,
                "inference_library": "hbis",
                "inference_library_version": __version__,
            },
        )

    def predict(
        self,
        ag: _t.Union[_t.Sequence[float], tuple[_t.Sequence[float], _t.Sequence[float]]],
        dt: _t.Optional[float] = None,
        draws: int = 1000,
        tail: float = 20.0,
        capacity: _t.Optional[float] = None,
    ) -> "Prediction":
        """The posterior's response to a ground motion (as ``hbis predict``):
        ``draws`` draws evenly spaced through the chains, each simulated from
        rest under the motion and ``tail`` seconds after; the base shear also
        in kN when the fit was given forces.

        The motion is the ``(t, ag)`` that :func:`ground_motion` and
        :func:`read_motion` return (``fit.predict(hbis.ground_motion())``;
        the step is taken from ``t``, which must be uniform), or ``ag``
        (m/s^2) and its step ``dt`` (s)."""
        if self.posterior is None:
            raise ValueError("predict(): a MAP-only fit has no posterior draws")
        pooled = self.posterior.reshape(-1, self.posterior.shape[-1])
        n = pooled.shape[0]
        idx = [i * n // draws for i in range(draws)] if draws < n else list(range(n))
        ag, dt = _motion(ag, dt)
        masses = None
        if self._raw.physical is not None:
            masses = list(self._raw.physical.reshape(-1, len(PHYSICAL))[idx, 0])
        return _predict(self.report["model"], pooled[idx], ag, dt, tail, capacity, masses, self.effects)

    def predict_suite(
        self,
        motions: _t.Union[int, _t.Sequence[tuple[_t.Sequence[float], _t.Sequence[float]]]],
        pga: _t.Union[None, float, str, _t.Sequence[_t.Union[float, str]]] = None,
        capacity: _t.Optional[float] = None,
        draws: int = 1000,
        tail: float = 20.0,
        seed: int = 1,
    ) -> "Prediction":
        """The posterior's response to a suite of ground motions, and a
        fragility curve (as ``hbis predict --motions --pga``, to the bit).

        ``motions``: a number ``n`` of synthetic Kanai-Tajimi motions (those
        of :func:`ground_motions` with ``seed``), or a list of ``(t, ag)``
        motions (:func:`read_motion`, :func:`ground_motion`). ``draws``
        draws evenly spaced through the chains are paired with the motions
        (``max(draws, motions)`` pairs, pair ``k`` taking draw ``k mod
        draws`` and motion ``k mod motions``), so the summary carries the
        record-to-record variability.

        ``pga``: a level in m/s^2 or ``"0.3g"``, or a list of them. The
        motions are scaled to the first (synthetic ones are drawn at it,
        default 0.3 g); several levels add :attr:`Prediction.fragility`,
        the probability of exceeding ``capacity`` (m, required then) at
        each level with its 95 % interval (the motions as clusters)."""
        if self.posterior is None:
            raise ValueError("predict_suite(): a MAP-only fit has no posterior draws")
        levels = [_pga(x, f"pga[{i}]") for i, x in enumerate(_levels(pga))]
        if isinstance(motions, bool) or not isinstance(motions, (int, _np.integer, list, tuple)):
            raise TypeError(f"motions: expected a number of motions or a list of (t, ag), got {type(motions).__name__}")
        if isinstance(motions, (int, _np.integer)):
            if not 1 <= int(motions) <= 10_000:
                raise ValueError(f"motions: {int(motions)}: expected 1 to 10000 synthetic motions")
            first = levels[0] if levels else 0.3 * G
            suite = [(t[1] - t[0], ag) for t, ag in ground_motions(int(motions), seed=seed, pga=first)]
            level = None
        else:
            if len(motions) == 0:
                raise ValueError("motions: the list is empty")
            suite = []
            for j, m in enumerate(motions):
                if not _is_pair(m):
                    raise TypeError(f"motions[{j}]: expected a (t, ag) motion")
                ag, dt = _motion(m, None)
                suite.append((dt, _np.ascontiguousarray(ag, dtype=float)))
            level = levels[0] if levels else None
        if len(levels) > 1 and capacity is None:
            raise ValueError("pga: several levels draw a fragility curve of the capacity: give capacity (m)")
        pooled = self.posterior.reshape(-1, self.posterior.shape[-1])
        n = pooled.shape[0]
        idx = [i * n // draws for i in range(draws)] if draws < n else list(range(n))
        masses = None
        if self._raw.physical is not None:
            masses = list(self._raw.physical.reshape(-1, len(PHYSICAL))[idx, 0])
        rows = [list(map(float, t)) for t in pooled[idx]]
        per_pair, pairs, text = _hbis.predict_suite(
            self.report["model"],
            rows,
            [(float(dt), list(map(float, ag))) for dt, ag in suite],
            float(tail),
            capacity,
            masses,
            effects=_effects(self.effects),
            pgas=levels if len(levels) > 1 else [],
            level=level,
        )
        return Prediction(per_pair, _json.loads(text), pairs=_np.asarray(pairs, dtype=int).reshape(-1, 2))

    def __repr__(self) -> str:
        conv = self.converged
        state = "MAP only" if conv is None else ("converged" if conv else "NOT converged")
        return f"Fit({self.report['model']}, {len(self.names)} parameters, {state})"


def _arrays(record) -> tuple[_np.ndarray, _np.ndarray, _t.Optional[float], str]:
    if isinstance(record, Record):
        return record.t, record.a, record.t0, record.source
    t, a = record
    return _np.ascontiguousarray(t, dtype=float), _np.ascontiguousarray(a, dtype=float), None, "array"


def fit(
    record,
    model: str = DEFAULT_MODEL,
    noise: str = "white",
    seed: int = 1,
    *,
    map_only: bool = False,
    ensembles: int = 2,
    walkers: _t.Optional[int] = None,
    tau_multiple: float = 50.0,
    max_steps: int = 20_000,
    ess: _t.Optional[float] = None,
    moves: _t.Optional[str] = None,
    max_evals: int = 200_000,
    evidence: bool = False,
    forces: _t.Optional[tuple[float, float]] = None,
    design_target: _t.Optional[float] = 0.5,
    thin: _t.Optional[int] = None,
    progress: _t.Optional[_t.Callable[[int, int, float], None]] = None,
    effects: _t.Sequence[str] = (),
    source: _t.Optional[str] = None,
) -> Fit:
    """Fits ``record`` (a :class:`Record` or a ``(t, a)`` pair) with ``model``.

    The defaults are ``hbis fit``'s: MAP by CMA-ES with restarts and a
    polish, then the ensemble sampler until the kept chain is 50
    autocorrelation times long and split R-hat <= 1.01. ``progress``, if
    given, is called as ``progress(steps, target_steps, tau_max)`` while
    sampling (e.g. to drive a tqdm bar); an exception it raises ends the fit
    and is raised here, and anything else than a callable or ``None`` is a
    ``TypeError``. The GIL is released while the fit runs, and Ctrl-C
    raises ``KeyboardInterrupt`` at once (the fit is abandoned).
    ``effects``: effect files (TOML) whose components ``model`` may
    name, as the binary's ``--effects``; :meth:`Fit.predict` uses them too.
    ``source``: the record's name in the report (``data.source``; default:
    the file a :class:`Record` was read from, else ``"array"``).

    A posterior sample that did not converge is returned, with a
    :class:`NotConvergedWarning` saying why (``hbis fit`` exits 3 then).
    """
    t, a, t0, named = _arrays(record)
    effects = _effects(effects)
    raw = _hbis.fit(
        t,
        a,
        model=model,
        noise=noise,
        seed=int(seed),
        t0=t0,
        map_only=map_only,
        ensembles=ensembles,
        walkers=walkers,
        tau_multiple=tau_multiple,
        max_steps=max_steps,
        ess=ess,
        moves=moves,
        max_evals=max_evals,
        evidence=evidence,
        forces=forces,
        design_target=design_target,
        thin=thin,
        progress=progress,
        effects=effects,
        source=named if source is None else str(source),
    )
    result = Fit(raw, int(seed), effects)
    if result.converged is False:
        _warnings.warn(
            "the posterior sample did not converge: "
            + result.report["sampling"]["not_converged"],
            NotConvergedWarning,
            stacklevel=2,
        )
    return result


class NotConvergedWarning(UserWarning):
    """Warned by :func:`fit` when its posterior sample did not converge
    (``Fit.converged`` is ``False``; the message gives
    ``report["sampling"]["not_converged"]``): the draws are probably not
    yet the posterior. ``hbis fit`` exits with status 3 in that case."""


def diagnose(
    record,
    model: str,
    noise: str = "white",
    seed: int = 1,
    *,
    effects: _t.Sequence[str] = (),
    candidates: _t.Optional[_t.Sequence[str]] = None,
    exclude: _t.Sequence[str] = (),
    source: _t.Optional[str] = None,
) -> dict[str, _t.Any]:
    """``hbis diagnose``: the fit of ``model``, its residual diagnosis and every
    catalog candidate ranked: ``diagnosis.json`` as a dict, key for key (the
    same runner makes both). ``effects``, ``candidates`` and ``exclude`` are
    the binary's ``--effects``, ``--candidates`` and ``--exclude``;
    ``source`` is ``data.source`` (default: the file a :class:`Record` was
    read from, else ``"array"``)."""
    t, a, t0, named = _arrays(record)
    return _json.loads(
        _hbis.diagnose(
            t,
            a,
            model,
            noise=noise,
            seed=int(seed),
            t0=t0,
            effects=_effects(effects),
            candidates=None if candidates is None else [str(c) for c in candidates],
            exclude=[str(c) for c in exclude],
            source=named if source is None else str(source),
        )
    )


def ladder(
    record,
    model: str,
    noise: str = "white",
    seed: int = 1,
    max_steps: int = 6,
    progress: _t.Optional[_t.Callable[[int, str], None]] = None,
    *,
    effects: _t.Sequence[str] = (),
    candidates: _t.Optional[_t.Sequence[str]] = None,
    exclude: _t.Sequence[str] = (),
    source: _t.Optional[str] = None,
) -> dict[str, _t.Any]:
    """``hbis ladder``: add the best supported effect, refit, repeat. Returns
    ``ladder.json`` as a dict, key for key (``model``, ``final_model``,
    ``steps``, ...); ``progress(k, model)`` is called after each step (an
    exception it raises ends the ladder and is raised here).
    ``effects``, ``candidates``, ``exclude`` and ``source`` are as in
    :func:`diagnose`."""
    t, a, t0, named = _arrays(record)
    return _json.loads(
        _hbis.ladder(
            t,
            a,
            model,
            noise=noise,
            seed=int(seed),
            t0=t0,
            max_steps=max_steps,
            progress=progress,
            effects=_effects(effects),
            candidates=None if candidates is None else [str(c) for c in candidates],
            exclude=[str(c) for c in exclude],
            source=named if source is None else str(source),
        )
    )


class Prediction:
    """The response to a ground motion of one or many parameter sets.

    Attributes
    ----------
    summary : dict
        ``peak_displacement``, ``residual_displacement``, ``peak_base_shear``
        (per unit mass), ``peak_total_acceleration`` (and ``peak_base_shear_kn``
        with masses), each ``{mean, sd, q05, q50, q95}``, as ``predict.json``.
    p_exceed_capacity : float or None
        Share of the draws (of the pairs, for a suite) whose peak
        displacement exceeds the capacity.
    p_exceed_ci : dict or None
        For a suite: that share with its 95 % interval, ``{p, low, high,
        effective_n}`` (the motions as clusters; ``predict.json``'s
        ``p_exceed_ci``).
    fragility : list of dict or None
        For a suite at several PGA levels: per level ``{pga_g, p_exceed,
        ci_low, ci_high, effective_pairs, pairs, peak_displacement}``, as
        ``predict.json``'s ``fragility``.
    pairs : numpy.ndarray
        ``(pairs, 2)``: the draw and the motion of each row of
        :attr:`per_draw` (the draws in order, motion 0, for one motion).
    per_draw : numpy.ndarray
        ``(draws, 4)``, or ``(pairs, 4)`` for a suite: the four quantities
        per draw or pair, in the order of :attr:`COLUMNS`.
    warnings : list of str
        Extrapolation beyond the release test, floored friction, units.
    extrapolation : dict
        How far the motion drives the draws beyond the release test
        (``predict.json``'s ``extrapolation``).
    report : dict
        The whole of ``predict.json``.
    COLUMNS : list of str
        The names of the columns of :attr:`per_draw`.
    """

    COLUMNS = ["peak_displacement", "residual_displacement", "peak_base_shear", "peak_total_acceleration"]

    def __init__(self, per_draw: _np.ndarray, report: dict[str, _t.Any], pairs: _t.Optional[_np.ndarray] = None):
        self.per_draw = per_draw
        self.report = report
        if pairs is None:
            pairs = _np.column_stack([_np.arange(len(per_draw)), _np.zeros(len(per_draw), dtype=int)])
        self.pairs: _np.ndarray = pairs
        self.p_exceed_ci: _t.Optional[dict[str, float]] = report.get("p_exceed_ci")
        self.fragility: _t.Optional[list[dict[str, _t.Any]]] = report.get("fragility")
        self.summary: dict[str, dict[str, float]] = report["summary"]
        self.p_exceed_capacity: _t.Optional[float] = report["p_exceed_capacity"]
        self.extrapolation: dict[str, float] = report["extrapolation"]
        self.warnings: list[str] = list(report["warnings"])

    def to_dataframe(self):
        """The per-draw quantities as a pandas DataFrame."""
        import pandas as pd

        return pd.DataFrame(self.per_draw, columns=self.COLUMNS)

    def __repr__(self) -> str:
        d = self.summary["peak_displacement"]
        return f"Prediction({self.per_draw.shape[0]} draws, peak displacement median {d['q50']:.4g} m)"


def _is_pair(motion) -> bool:
    """Whether ``motion`` is a ``(t, ag)`` pair of 1-D sequences (a plain
    ``ag`` of two samples is a pair of numbers, not of sequences)."""
    return (
        isinstance(motion, (tuple, list))
        and len(motion) == 2
        and all(_np.ndim(x) == 1 for x in motion)
    )


def _motion(ag, dt) -> tuple[_np.ndarray, float]:
    """``(ag, dt)`` of a motion given as the ``(t, ag)`` of
    :func:`ground_motion`/:func:`read_motion` or as ``ag`` and ``dt``."""
    if not _is_pair(ag):
        if dt is None:
            raise TypeError(
                "dt: missing: give the motion as the (t, ag) that hbis.ground_motion and "
                "hbis.read_motion return, or as ag and its step dt"
            )
        return ag, float(dt)
    t = _np.asarray(ag[0], dtype=float)
    a = _np.asarray(ag[1], dtype=float)
    if len(t) != len(a):
        raise ValueError(f"ag: a (t, ag) motion needs one t per sample, got {len(t)} times for {len(a)} samples")
    if len(t) < 2:
        raise ValueError(f"ag: a (t, ag) motion needs at least 2 samples for its step, got {len(t)}")
    step = float(t[1] - t[0])
    if not step > 0.0 or not _np.isfinite(step):
        raise ValueError(f"ag: t must increase: t[0] = {float(t[0])!r} s, t[1] = {float(t[1])!r} s")
    # The tolerance of the library's two-column motion reader.
    expected = t[0] + _np.arange(len(t)) * step
    tol = 1e-6 * _np.maximum(step, _np.abs(expected) * 1e-3) + 1e-9
    off = ~(_np.abs(t - expected) <= tol)
    if off.any():
        k = int(_np.argmax(off))
        raise ValueError(
            f"ag: t[{k}] = {float(t[k])!r} s, expected {float(expected[k])!r} s ({k} steps of {step!r} s after t[0]; "
            "a motion must be uniformly sampled)"
        )
    if isinstance(dt, str):
        raise TypeError(f"dt: got the string {dt!r}; after a (t, ag) motion give model by keyword (model={dt!r})")
    if dt is not None and not abs(float(dt) - step) <= 1e-9 * step:
        raise ValueError(f"dt: {dt!r} s, but the step of the (t, ag) motion is {step!r} s; give dt only with ag alone")
    return a, step


def _predict(model, thetas, ag, dt, tail, capacity, masses, effects=(), mass=None) -> Prediction:
    rows = [list(map(float, t)) for t in _np.atleast_2d(_np.asarray(thetas, dtype=float))]
    ag = _np.ascontiguousarray(ag, dtype=float)
    per_draw, text = _hbis.predict(
        model,
        rows,
        float(dt),
        ag,
        float(tail),
        capacity,
        masses,
        effects=_effects(effects),
        mass=None if mass is None else float(mass),
    )
    return Prediction(per_draw, _json.loads(text))


def predict(
    params: dict[str, float],
    ag: _t.Union[_t.Sequence[float], tuple[_t.Sequence[float], _t.Sequence[float]]],
    dt: _t.Optional[float] = None,
    model: str = DEFAULT_MODEL,
    tail: float = 20.0,
    capacity: _t.Optional[float] = None,
    mass: _t.Optional[float] = None,
    *,
    effects: _t.Sequence[str] = (),
) -> Prediction:
    """One parameter set's response to a ground motion from rest, ``tail``
    seconds after it ends (``hbis predict --model --params``). For a fitted
    posterior use :meth:`Fit.predict`.
    The motion is the ``(t, ag)`` that :func:`ground_motion` and
    :func:`read_motion` return (the step is taken from ``t``, which must be
    uniform), or ``ag`` (m/s^2) and its step ``dt`` (s); give ``model`` by
    keyword after a ``(t, ag)``.
    ``mass`` (t) adds the base shear in kN; it and ``capacity`` (m) must be
    finite and > 0, as ``--mass`` and ``--capacity``.
    ``effects``: effect files whose components ``model`` may name."""
    names = param_names(model, effects=effects)
    extra = sorted(set(params) - set(names))
    if extra:
        raise ValueError(f"params: {extra[0]!r} is not a parameter of {model} (its parameters: {', '.join(names)})")
    missing = [n for n in names if n not in params]
    if missing:
        raise ValueError(f"params: {missing[0]!r} is missing (the parameters of {model}: {', '.join(names)})")
    ag, dt = _motion(ag, dt)
    theta = [[float(params[n]) for n in names]]
    return _predict(model, theta, ag, dt, tail, capacity, None, effects, mass=mass)


def ground_motion(
    seed: int = 1, pga: float = 0.3 * 9.80665, duration: float = 40.0, dt: float = 0.01
) -> tuple[_np.ndarray, _np.ndarray]:
    """A synthetic Kanai-Tajimi motion (firm soil), seeded: ``(t, ag)`` in s,
    m/s^2, which :func:`predict` and :meth:`Fit.predict` take as it is."""
    ag = _hbis.kanai_tajimi(int(seed), float(pga), float(duration), float(dt))
    return _np.arange(len(ag)) * dt, ag


def ground_motions(
    n: int, seed: int = 1, pga: float = 0.3 * 9.80665, duration: float = 40.0, dt: float = 0.01
) -> list[tuple[_np.ndarray, _np.ndarray]]:
    """A suite of ``n`` synthetic Kanai-Tajimi motions, motion ``j`` of seed
    ``suite_seed(seed, j)``: those of ``hbis predict --motions n --seed
    seed``, each ``(t, ag)`` as :func:`ground_motion` returns it."""
    return [ground_motion(_hbis.suite_seed(int(seed), j), pga, duration, dt) for j in range(int(n))]


def _levels(pga) -> list:
    if pga is None:
        return []
    if isinstance(pga, (str, float, int, _np.floating, _np.integer)):
        return [pga]
    return list(pga)


def _pga(x, name: str) -> float:
    """A PGA in m/s^2 from a number (m/s^2) or a string ``"2.94"``,
    ``"0.3g"``, as ``--pga`` reads it."""
    try:
        if isinstance(x, str):
            t = x.strip()
            v = float(t[:-1]) * G if t[-1:] in ("g", "G") else float(t)
        else:
            v = float(x)
    except (ValueError, TypeError):
        raise ValueError(f"{name}: {x!r}: expected an acceleration > 0 in m/s^2 (2.94) or in g ('0.3g')") from None
    if not (_np.isfinite(v) and v > 0.0):
        raise ValueError(f"{name}: {x!r}: expected an acceleration > 0 in m/s^2 (2.94) or in g ('0.3g')")
    return v


def read_motion(path: str, units: _t.Optional[str] = None) -> tuple[_np.ndarray, _np.ndarray]:
    """A PEER ``.AT2`` file (its unit from the header) or two columns ``t ag``
    (``units`` = ``'g'``, ``'m/s2'`` or ``'mm/s2'`` required): ``(t, ag)`` in s,
    m/s^2, which :func:`predict` and :meth:`Fit.predict` take as it is."""
    dt, ag = _hbis.read_motion(str(path), units)
    return _np.arange(len(ag)) * dt, ag


__all__ = [
    "DEFAULT_MODEL",
    "G",
    "PHYSICAL",
    "PHYSICAL_UNITS",
    "Fit",
    "NotConvergedWarning",
    "Prediction",
    "Record",
    "Synthetic",
    "diagnose",
    "fit",
    "ground_motion",
    "ground_motions",
    "ladder",
    "param_names",
    "predict",
    "read_motion",
    "simulate",
    "synthesize",
    "table_8_1",
]
