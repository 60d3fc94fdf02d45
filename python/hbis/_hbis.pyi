"""Type stubs of the compiled part of hbis (``hbis._hbis``). Use the
wrappers in ``hbis`` (``hbis.fit``, ``hbis.Record``, ...) rather than these.

Arrays (``t``, ``a``, ``ag``) must be 1-D float64 numpy arrays (any
strides); integers (``seed``, ``n``, ``walkers``, ...) non-negative ``int``s.
Otherwise a ``ValueError`` (a ``TypeError`` for a wrong type) names the
argument. ``simulate``, ``fit``, ``diagnose``, ``ladder`` and ``predict``
run with the GIL released and raise ``KeyboardInterrupt`` on Ctrl-C at
once; an exception raised by a ``progress`` callback ends the run and is
raised from the call."""

from typing import Callable, Dict, List, Optional, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

Array = npt.NDArray[np.float64]

def table_8_1(k: int) -> Dict[str, float]: ...
def param_names(model: str, effects: List[str] = ...) -> List[str]: ...
def simulate(
    model: str, params: Dict[str, float], dt: float, duration: float, effects: List[str] = ...
) -> Tuple[Array, Array, Array, Array]: ...
def synthesize(
    model: str, params: Dict[str, float], dt: float, n: int, noise: float, seed: int, effects: List[str] = ...
) -> Tuple[Array, Array, Array, float]: ...
def read_record(path: str, units: str = "m/s2") -> Tuple[Array, Array]: ...
def align(t: Array, a: Array, t0: Optional[float] = None) -> Tuple[Array, Array, float, str]: ...

class FitResult:
    names: List[str]
    report_json: str
    thin: int
    @property
    def draws(self) -> Optional[Array]: ...
    @property
    def log_prob(self) -> Optional[Array]: ...
    @property
    def physical(self) -> Optional[Array]: ...

def fit(
    t: Array,
    a: Array,
    model: str = "trilinear+lcfm+viscous",
    noise: str = "white",
    seed: int = 1,
    t0: Optional[float] = None,
    map_only: bool = False,
    ensembles: int = 2,
    walkers: Optional[int] = None,
    tau_multiple: float = 50.0,
    max_steps: int = 20000,
    ess: Optional[float] = None,
    moves: Optional[str] = None,
    max_evals: int = 200000,
    evidence: bool = False,
    forces: Optional[Tuple[float, float]] = None,
    design_target: Optional[float] = 0.5,
    thin: Optional[int] = None,
    source: str = "array",
    progress: Optional[Callable[[int, int, float], None]] = None,
    effects: List[str] = ...,
) -> FitResult: ...
def diagnose(
    t: Array,
    a: Array,
    model: str,
    noise: str = "white",
    seed: int = 1,
    t0: Optional[float] = None,
    effects: List[str] = ...,
    candidates: Optional[List[str]] = None,
    exclude: List[str] = ...,
    source: str = ...,
) -> str: ...
def ladder(
    t: Array,
    a: Array,
    model: str,
    noise: str = "white",
    seed: int = 1,
    t0: Optional[float] = None,
    max_steps: int = 6,
    progress: Optional[Callable[[int, str], None]] = None,
    effects: List[str] = ...,
    candidates: Optional[List[str]] = None,
    exclude: List[str] = ...,
    source: str = ...,
) -> str: ...
def kanai_tajimi(
    seed: int, pga: float = ..., duration: float = 40.0, dt: float = 0.01, f_g: float = 2.5, zeta_g: float = 0.6
) -> Array: ...
def read_motion(path: str, units: Optional[str] = None) -> Tuple[float, Array]: ...
def predict(
    model: str,
    thetas: List[List[float]],
    dt: float,
    ag: Array,
    tail: float = 20.0,
    capacity: Optional[float] = None,
    masses: Optional[List[float]] = None,
    effects: List[str] = ...,
    mass: Optional[float] = None,
) -> Tuple[Array, str]: ...
def suite_seed(seed: int, j: int) -> int: ...
def predict_suite(
    model: str,
    thetas: List[List[float]],
    motions: List[Tuple[float, Array]],
    tail: float = 20.0,
    capacity: Optional[float] = None,
    masses: Optional[List[float]] = None,
    effects: List[str] = ...,
    pgas: List[float] = ...,
    level: Optional[float] = None,
) -> Tuple[Array, List[Tuple[int, int]], str]: ...
