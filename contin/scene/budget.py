"""What a scene asks of the machine: memory and work, estimated at check time, refused when it cannot be done.

A scene's sizes are each within their schema's limits (``harmonics`` up to
2000, ``samples`` up to 2**20, ...), but together they can ask for more
memory than any machine has: 200 dofs with 2000 harmonics make a
800200 x 800200 Jacobian (4.66 TiB). Each analysis estimates, with the
functions here (``frequency_response_demands``, ...: its
:meth:`~contin.analyses.base.Analysis.demands`), from the scene and its built
model and before any array is made, the largest
arrays each analysis holds at once and the work of its largest single
computation, and refuses with a :class:`SceneError` naming the key that sets
the size, the sizes, the bytes and the limit:

- harmonic balance: the unknowns ``n (2H+1)`` (condensed onto the dofs with
  nonlinear forces when ``condense: true``), the AFT samples (``N x n x n``
  force Jacobians), the dense Jacobian with its factors and copies;
- stability: Hill's eigenproblem (a ``2m x 2m`` matrix, ``m = n (2H+1)``) and
  the monodromy (``2 S x n x n`` Jacobians along the orbit for ``S`` steps per
  period);
- quasi-periodic tori (``switch: [ns]``): their unknowns and ``N1 x N2`` grid;
- time simulations (``simulate``, ``start_from: simulation``): the recorded
  samples, the Poincare section of every revolution and the RK4 steps;
- ``frf``: the impedance matrices of every frequency; ``modes``: the modes of
  every value; fold and period-doubling curves: their extended systems.

The memory limit is :data:`MEMORY_FRACTION` of the memory available when the
scene is checked (:func:`machine_memory`: ``MemAvailable`` of
``/proc/meminfo``, bounded by a cgroup's ``memory.max`` and by
``RLIMIT_AS``), never below :data:`MEMORY_FLOOR` (or half the physical
memory, if less) so that a briefly busy machine does not refuse small scenes.
Work is counted in floating-point operations of one indivisible computation
(one continuation point's factorisation, eigenproblem or monodromy, a whole
simulation) and refused beyond :data:`MAX_SECONDS` at the optimistic rate of
:data:`OPERATIONS_PER_SECOND`: a refusal is sure, an accepted scene may still
be slow. The estimates count the arrays that scale with the sizes, so they are
lower bounds within a small factor (docs/reference/scene-checks.md).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Callable

from contin.hb.condensation import nonlinear_dofs
from contin.hb.harmonics import default_samples
from contin.scene.files import size_text
from contin.scene.schema import SceneError, is_int, is_number
from contin.stability.options import StabilityOptions

__all__ = ["MEMORY_FRACTION", "MEMORY_FLOOR", "OPERATIONS_PER_SECOND", "MAX_SECONDS", "JACOBIAN_COPIES", "Limits",
           "Demand", "machine_memory", "check_resources", "check_demands", "harmonic_balance_demands",
           "time_text", "frequency_response_demands", "bifurcation_curve_demands", "backbone_demands",
           "simulate_demands", "frf_demands", "modes_demands"]

#: share of the available memory a scene may ask for (the rest: Python, numba, the plots, other programs)
MEMORY_FRACTION = 0.8
#: the limit is never below this, or half the physical memory if that is less (bytes)
MEMORY_FLOOR = 2 * 2**30
#: floating-point operations per second assumed for one core: optimistic, so a refused scene surely takes longer
OPERATIONS_PER_SECOND = 1e10
#: longest single computation accepted at :data:`OPERATIONS_PER_SECOND` (seconds): one day
MAX_SECONDS = 86400.0
#: arrays of the Jacobian's size held at once along a branch: the Jacobian and the linear operator's parts, the
#: LU factors, the bordered system and copies (11 to 12 measured at 1240 and 2460 unknowns)
JACOBIAN_COPIES = 12
#: doubles held per entry of the ``m x m`` blocks of Hill's method: its three matrices, the companion matrix and
#: its copy in the eigensolver (4 blocks each), the complex eigenvectors (8) and the solved blocks (31 measured)
HILL_DOUBLES = 32


def time_text(seconds: float) -> str:
    """``3.2 h``, ``47 days``: a duration in its largest sensible unit."""
    for unit, size in (("years", 365.25 * 86400), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            value = f"{seconds / size:.3g}"
            return f"{value} {unit[:-1] if value == '1' and unit.endswith('s') else unit}"
    return f"{seconds:.3g} s"


def _read_number(path: str, prefix: str | None = None, scale: float = 1.0) -> float | None:
    try:
        with open(path, encoding="ascii", errors="replace") as fh:
            for line in fh:
                if prefix is None:
                    text = line.strip()
                    return None if text == "max" else float(text) * scale
                if line.startswith(prefix):
                    return float(line.split()[1]) * scale
    except (OSError, ValueError, IndexError):
        return None
    return None


def machine_memory() -> tuple[float, float | None, str]:
    """``(available, hard, where)``: bytes available now, a hard limit of this process (or None), and their source.

    ``available`` is ``MemAvailable`` of ``/proc/meminfo`` (else the free
    physical pages of ``sysconf``, else the physical memory); ``hard`` the
    least of a cgroup v2 ``memory.max`` (less its ``memory.current``) and
    ``RLIMIT_AS`` (less the address space in use), where set.
    """
    avail = _read_number("/proc/meminfo", "MemAvailable:", 1024.0)
    where = "available (MemAvailable)"
    if avail is None:
        try:
            avail = float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
            where = "free"
        except (ValueError, OSError, AttributeError):
            avail, where = float(_physical() or 2**34), "physical"
    hard = []
    cg_max = _read_number("/sys/fs/cgroup/memory.max")
    if cg_max is not None:
        hard.append(cg_max - (_read_number("/sys/fs/cgroup/memory.current") or 0.0))
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft not in (resource.RLIM_INFINITY, -1):
            hard.append(soft - (_read_number("/proc/self/status", "VmSize:", 1024.0) or 0.0))
    except (ImportError, ValueError, OSError):
        pass
    return avail, (max(min(hard), 0.0) if hard else None), where


def _physical() -> float | None:
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


@dataclass(frozen=True)
class Limits:
    """What a scene may ask: ``memory`` (bytes held at once) and ``seconds`` of one computation at ``rate``.

    Parameters
    ----------
    memory : float
        Bytes the largest set of arrays held at once may take.
    basis : str
        How ``memory`` was found, for messages (``"80% of the 22.5 GiB available (MemAvailable) is 18 GiB"``);
        empty: the number itself.
    seconds : float
        Longest single computation accepted, at ``rate``.
    rate : float
        Floating-point operations per second assumed.

    Raises
    ------
    ValueError
        Naming the field, for a value that is not a positive finite number (or a ``basis`` that is no string).
    """

    memory: float
    basis: str = ""
    seconds: float = MAX_SECONDS
    rate: float = OPERATIONS_PER_SECOND

    def __post_init__(self):
        for name in ("memory", "seconds", "rate"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise ValueError(f"Limits.{name}: expected a positive finite number, found {v!r}")
        if not isinstance(self.basis, str):
            raise ValueError(f"Limits.basis: expected a string, found {self.basis!r}")

    @classmethod
    def of_machine(cls) -> "Limits":
        """:data:`MEMORY_FRACTION` of the memory available now (see :func:`machine_memory`), at least
        :data:`MEMORY_FLOOR` or half the physical memory, within the process's hard limit."""
        avail, hard, where = machine_memory()
        phys = _physical()
        if hard is not None and hard < avail:
            limit = MEMORY_FRACTION * max(hard, 1.0)
            return cls(limit, f"{MEMORY_FRACTION:.0%} of the {size_text(hard)} allowed to this process (cgroup "
                              f"memory.max or ulimit -v) is {size_text(limit)}")
        floor = MEMORY_FLOOR if phys is None else min(MEMORY_FLOOR, 0.5 * phys)
        limit = MEMORY_FRACTION * max(avail, 1.0)
        if limit < floor:
            return cls(floor, f"{size_text(floor)}, the least limit ({MEMORY_FRACTION:.0%} of the "
                              f"{size_text(avail)} {where} is less)")
        return cls(limit, f"{MEMORY_FRACTION:.0%} of the {size_text(avail)} {where} is {size_text(limit)}")

    @property
    def operations(self) -> float:
        return self.seconds * self.rate


@dataclass(frozen=True)
class Demand:
    """Arrays and work one part of a run asks for.

    Parameters
    ----------
    key : str
        The scene key that sets the size (named in a refusal).
    what : str
        The sizes in words: ``"200 dofs x 4001 coefficients need a 800200 x 800200 Jacobian"``.
    nbytes : float
        Bytes of its arrays held at once.
    operations : float
        Floating-point operations of its largest single computation.
    advice : str
        What would make it smaller (appended to a refusal).
    """

    key: str
    what: str
    nbytes: float
    operations: float = 0.0
    advice: str = ""


# ---------------------------------------------------------------- the pieces
def _rk4_step(n: int) -> float:
    """Operations of one RK4 step of ``n`` dofs: four force and ``M^-1`` evaluations, and the loop's own cost."""
    return 4.0 * (6.0 * n * n + 50.0)


def harmonic_balance_demands(n: int, H: int, samples: int, key_h: str, key_s: str | None = None,
                             n_engine: int | None = None, extra_unknowns: int = 0) -> list[Demand]:
    """The AFT arrays and the Newton step of a periodic harmonic balance.

    Parameters
    ----------
    n : int
        Dofs of the model (the AFT samples every one).
    H, samples : int
        Harmonics and AFT samples per period.
    key_h, key_s : str
        Keys of the harmonics and of the samples (None: the samples follow from H).
    n_engine : int, optional
        Dofs the continuation follows (fewer when condensed).
    extra_unknowns : int
        Unknowns beyond the coefficients (a backbone's frequency and amplitude).
    """
    n_e = n if n_engine is None else n_engine
    m = n_e * (2 * H + 1) + extra_unknowns
    jac = 8.0 * m * m
    aft = 8.0 * samples * (n + 2.0 * n * n) * 2.0
    cond = "" if n_e == n else f" (condensed from {n})"
    out = [Demand(key_h, f"{_dofs(n_e)}{cond} x {2 * H + 1} coefficients need a {m} x {m} Jacobian of "
                         f"{size_text(jac)}, and {JACOBIAN_COPIES} arrays of its size with the factors and copies",
                  JACOBIAN_COPIES * jac, 2.0 / 3.0 * m**3 + 8.0 * samples * n * n * (2 * H + 1),
                  "fewer harmonics" + (", or condense: true (a model with linear dofs)" if n_e == n else ""))]
    out.append(Demand(key_s or key_h, f"{samples} AFT samples of {_dofs(n)} need {samples} x {n} x {n} force "
                                      "Jacobians", aft, 0.0, "fewer samples" if key_s else "fewer harmonics"))
    return out


def _hill(n: int, H: int, key: str, method: str) -> Demand:
    m = n * (2 * H + 1)
    return Demand(key, f"Hill's method (stability: {method}) on {_dofs(n)} x {2 * H + 1} coefficients needs the "
                       f"eigenvalues and eigenvectors of a {2 * m} x {2 * m} matrix", 8.0 * HILL_DOUBLES * m * m,
                  25.0 * (2 * m) ** 3, "stability: floquet (the monodromy of 2n variational equations), or fewer "
                                       "harmonics")


def _monodromy(n: int, steps: int, key: str) -> Demand:
    return Demand(key, f"a monodromy of {steps} RK4 steps per period on {_dofs(n)} keeps {2 * steps} x {n} x {n} "
                       "force Jacobians along the orbit", 8.0 * 2 * steps * (2.0 * n * n + 4.0 * n),
                  steps * (32.0 * n**3 + 16.0 * n * n + 100.0), "fewer stability_options.steps_per_period")


def _simulation(n: int, revolutions: float, steps: int, key: str, what: str, runs: float = 1.0) -> Demand:
    """A time simulation of ``revolutions`` of ``steps`` RK4 steps, its state kept at every revolution."""
    return Demand(key, f"{what}: {_count(revolutions)} revolutions of {steps} RK4 steps of {_dofs(n)} (the state "
                       "kept at each revolution)", 8.0 * (revolutions + 2.0) * 4.0 * n,
                  runs * revolutions * steps * _rk4_step(n), "fewer revolutions or steps per period")


def _dofs(n: int) -> str:
    return "1 dof" if n == 1 else f"{n} dofs"


def _count(x: float) -> str:
    """An integral count as digits, anything else (or beyond 1e15) in ``%g`` form."""
    x = float(x)
    return str(int(x)) if x.is_integer() and abs(x) < 1e15 else f"{x:.4g}"


def _samples(model, H: int, samples) -> int:
    if is_int(samples) and samples > 0:
        return int(samples)
    return int(max(default_samples(H, model.degree), model.min_samples, 2 * H + 1))


def _condensed_dofs(model, how) -> int:
    """Dofs the continuation follows: those with nonlinear forces when ``condense: true``, else all
    (``auto`` condenses only where the eliminated blocks are regular: all are counted)."""
    n = model.n_dof
    if how is not True or not model.forces:
        return n
    try:
        kept, _ = nonlinear_dofs(model)
    except ValueError:
        return n
    return len(kept) if kept else n


def _int(v, default: int) -> int:
    return int(v) if is_int(v) and v > 0 else default


def _num(v, default: float) -> float:
    return float(v) if is_number(v) and v > 0 else default


# ---------------------------------------------------------------- the analyses
def _starts(a: dict):
    """``(source of key k, merged analysis)`` of the scene and each of its ``starts``."""
    yield (lambda k: f"analysis.{k}"), a
    for i, extra in enumerate(a.get("starts") or ()):
        if isinstance(extra, dict):
            merged = {**a, **extra}
            yield (lambda k, i=i, extra=extra: f"analysis.starts[{i}].{k}" if k in extra else f"analysis.{k}"), merged


def _periodic(model, a: dict, src: Callable, condense=False) -> tuple[list[Demand], int, int]:
    H = _int(a.get("harmonics"), 5)
    N = _samples(model, H, a.get("samples"))
    key_s = src("samples") if is_int(a.get("samples")) else None
    return harmonic_balance_demands(model.n_dof, H, N, src("harmonics"), key_s, _condensed_dofs(model, condense)), H, N


def _stability(model, a: dict, src: Callable, H: int) -> list[Demand]:
    method = a.get("stability", "none")
    opts = a.get("stability_options") if isinstance(a.get("stability_options"), dict) else {}
    n = model.n_dof
    out = []
    if method in ("hill", "both"):
        out.append(_hill(n, H, "analysis.stability", method))
    if method in ("floquet", "both"):
        default = StabilityOptions.steps_per_period
        steps = max(_int(opts.get("steps_per_period"), default), H + 1)
        out.append(_monodromy(n, steps, src("stability_options") + ".steps_per_period"))
    return out


def _start_simulation(model, a: dict, src: Callable) -> list[Demand]:
    if a.get("start_from") != "simulation" or a.get("guess") is not None:
        return []
    s = a.get("start_simulation") if isinstance(a.get("start_simulation"), dict) else {}
    T, S = _num(s.get("transient"), 500.0), _int(s.get("steps_per_period"), 4096)
    runs = 1 + (len(s["run_up"]) if isinstance(s.get("run_up"), list) else 0)
    return [_simulation(model.n_dof, T, S, src("start_simulation") + ".transient", "the start from a simulation",
                        runs)]


def _torus(model, a: dict, H: int) -> list[Demand]:
    switch = a.get("switch") or ()
    if "ns" not in switch:
        return []
    t = a.get("torus") if isinstance(a.get("torus"), dict) else {}
    n = model.n_dof
    H1, H2 = _int(t.get("harmonics"), H), _int(t.get("harmonics2"), 3)
    N1 = _int(t.get("samples"), max(default_samples(H1, model.degree), model.min_samples, 2 * H1 + 1))
    N2 = _int(t.get("samples2"), max(default_samples(H2, model.degree), 2 * H2 + 1))
    size = n * (2 * (1 + H2 + H1 * (2 * H2 + 1)) - 1) + 1
    jac = 8.0 * size * size
    out = [Demand("analysis.torus", f"tori of {_dofs(n)} with harmonics ({H1}, {H2}) have {size} unknowns: a {size} x "
                                    f"{size} Jacobian of {size_text(jac)}, and a {N1} x {N2} grid of {n} x {n} force "
                                    "Jacobians", JACOBIAN_COPIES * jac + 8.0 * N1 * N2 * (n + 2.0 * n * n) * 2.0,
                  2.0 / 3.0 * size**3, "fewer torus harmonics or samples")]
    if t.get("stability", "simulation") == "simulation":
        P, S = _num(t.get("periods"), 200.0), _int(t.get("steps_per_period"), 256)
        out.append(_simulation(n, P, S, "analysis.torus", "the stability check of each torus point"))
    return out


def frequency_response_demands(scene, model) -> list[list[Demand]]:
    groups = []
    a = scene.analysis
    for src, merged in _starts(a):
        hb, H, _ = _periodic(model, merged, src, merged.get("condense", "auto"))
        groups.append(hb + _stability(model, merged, src, H) + _torus(model, merged, H))
        groups.append(_start_simulation(model, merged, src))
    return groups


def bifurcation_curve_demands(scene, model) -> list[list[Demand]]:
    a = scene.analysis
    src = lambda k: f"analysis.{k}"  # noqa: E731
    hb, H, N = _periodic(model, a, src)
    n = model.n_dof
    curves = []
    for kind in a.get("curves") or ():
        # a period-doubling curve works with the order-2 nu Jacobian (2H harmonics), a fold curve with its own
        m = n * (4 * H + 1) if kind == "pd" else n * (2 * H + 1) + 2
        curves.append(Demand("analysis.harmonics", f"{kind} curves of {_dofs(n)} x {2 * H + 1} coefficients need "
                                                   f"{m} x {m} extended Jacobians", 8.0 * JACOBIAN_COPIES * m * m,
                             2.0 / 3.0 * m**3, "fewer harmonics"))
    return [hb + _stability(model, a, src, H), hb + curves, _start_simulation(model, a, src)]


def backbone_demands(scene, model) -> list[list[Demand]]:
    a = scene.analysis
    H = _int(a.get("harmonics"), 5)
    N = _samples(model, H, a.get("samples"))
    key_s = "analysis.samples" if is_int(a.get("samples")) else None
    return [harmonic_balance_demands(model.n_dof, H, N, "analysis.harmonics", key_s, extra_unknowns=2)]


def simulate_demands(scene, model) -> list[list[Demand]]:
    a = scene.analysis
    n = model.n_dof
    T = float(a["transient"]) if is_number(a.get("transient")) and a["transient"] >= 0 else 500.0
    R = 2 * math.ceil(_int(a.get("record"), 100) / 2.0)  # as steady_state rounds it
    S, spp = _int(a.get("steps_per_period"), 4096), _int(a.get("samples_per_period"), 64)
    values = len(a["values"]) if isinstance(a.get("values"), list) else 1
    obs = len(a["dofs"]) if isinstance(a.get("dofs"), list) else min(2, n)
    recorded = R * spp + 1.0
    # the states and their copies, the classification's spectra, and each value's observed dofs for the plot
    record = Demand("analysis.record", f"{_count(R)} recorded revolutions x {spp} samples of {_dofs(n)}",
                    8.0 * recorded * (4.0 * n + 4.0) + 8.0 * values * recorded * (obs + 1.0), 0.0,
                    "fewer record revolutions or samples_per_period")
    steps = _simulation(n, T + R, S, "analysis.transient" if T >= R else "analysis.record",
                        f"{values} simulated value(s)", values)
    return [[record, steps]]


def frf_demands(scene, model) -> list[list[Demand]]:
    a = scene.analysis
    n = model.n_dof
    points = _int(a.get("points"), 400)
    force = a.get("force")
    cases = len(force) if isinstance(force, list) else 1
    nbytes = cases * points * (32.0 * n * n + 100.0 * n + 200.0)
    return [[Demand("analysis.points", f"{cases} force case(s) at {points} frequencies of {_dofs(n)} keep {points} "
                                       f"x {n} x {n} complex impedances", nbytes,
                    cases * points * (8.0 / 3.0 * n**3 + 64.0 * n * n), "fewer points")]]


def modes_demands(scene, model) -> list[list[Demand]]:
    a = scene.analysis
    n = model.n_dof
    if isinstance(a.get("values"), list):
        count, key = len(a["values"]), "analysis.values"
    elif a.get("range") is not None:
        count, key = _int(a.get("points"), 21), "analysis.points"
    else:
        count, key = 1, "analysis.values"
    return [[Demand(key, f"the modes of {_dofs(n)} at {count} values (their shapes and damped eigenvectors)",
                    count * 100.0 * n * n + 8.0 * 64 * n * n, count * 200.0 * n**3, "fewer values")]]


def check_demands(groups, limits: Limits, lines: dict | None = None) -> None:
    """Refuse the first demand (or group of demands held at once) beyond ``limits``.

    Raises
    ------
    SceneError
        Naming the demand's key, with its sizes, its bytes or operations and the limit.
    """
    lines = lines or {}
    mem = f"arrays that fit in memory: {limits.basis or size_text(limits.memory)}"
    for group in groups:
        for d in group:
            if d.nbytes > limits.memory:
                raise SceneError(d.key, mem, None, lines.get(d.key), hint=f": {_sentence(d, limits)}")
            if d.operations > limits.operations:
                raise SceneError(d.key, f"work of at most {time_text(limits.seconds)} for one computation at "
                                 f"{limits.rate:.3g} operations per second", None, lines.get(d.key),
                                 hint=f": {_sentence(d, limits)}")
        total = sum(d.nbytes for d in group)
        if total > limits.memory:
            big = max(group, key=lambda d: d.nbytes)
            rest = "; ".join(f"{d.what}: {size_text(d.nbytes)}" for d in group)
            raise SceneError(big.key, mem, None, lines.get(big.key),
                             hint=f": together {size_text(total)}: {rest}{_advice(big)}")


def _sentence(d: Demand, limits: Limits) -> str:
    """``what: 18.6 TiB in all, about 3.4e+17 operations (at least 1.08 years at 1e+10 per second); use ...``."""
    work = ""
    if d.operations > 0:
        work = (f", about {d.operations:.2g} operations (at least {time_text(d.operations / limits.rate)} at "
                f"{limits.rate:.3g} per second)")
    return f"{d.what}: {size_text(d.nbytes)} in all{work}{_advice(d)}"


def _advice(d: Demand) -> str:
    return f"; use {d.advice}" if d.advice else ""


def check_resources(scene, groups, limits: Limits | None = None) -> list[list[Demand]]:
    """Refuse what ``scene`` asks beyond the machine: ``groups``, its analysis's estimate
    (:meth:`contin.analyses.base.Analysis.demands`, made from the scene and its built model).

    Made by :func:`contin.scene.registry.check_scene` before the analysis's
    plan, which builds the problems (and their arrays).

    Parameters
    ----------
    scene : Scene
    groups : list of list of Demand
        Demands held at once, by group.
    limits : Limits, optional
        Default :meth:`Limits.of_machine`.

    Returns
    -------
    list of list of Demand
        The groups that are not empty.

    Raises
    ------
    SceneError
        See :func:`check_demands`.
    """
    groups = [g for g in groups if g]
    if groups:
        check_demands(groups, limits or Limits.of_machine(), scene.lines)
    return groups
