"""The rotor's Fig. 4 from the equations of motion: the 1/2-subharmonic branch from one period doubling to the other.

Inagaki, Ishida & Hayashi (2005) draw, at f0 = 0.5 and with m = 10 harmonics of w/2, one
1/2-subharmonic branch F-E-C-B-D: it leaves the zero-amplitude (harmonic) solution at the
period doubling F, turns at the fold E (the jump), is stable from E down to the fold C
and returns unstable to the harmonic solution at the period doubling D. The converged
harmonic balance of scenes/rotor_f0_05.yaml follows it only where the bearing stays on
its casing (README, "Bearing rotor"). This script follows it on the flow map of the time
integrator itself (contin.timedomain.shooting: compiled RK4 with the contact switches located, 4096
steps per revolution; the orbit's period is two revolutions, shot as one segment), where
the bearing bounces too. The Jacobian is the central difference of the flow map
(``jacobian="differences"``), so the reference shares no code with the variational
equations of the production discretisation:

1. the period doublings of the harmonic orbit of the flow, located on a grid of w
   (period_doubling_scan, started from the harmonic balance): D and F;
2. the branch switched at F (period_doubling_start), followed by the continuation engine
   with the flow's multipliers (ShootingStability: folds, period doublings,
   Neimark-Sacker and branch points located) until it returns to the harmonic orbit.
   Where the bearing starts or stops bouncing on its casing (grazing) the flow map's
   derivative jumps and the branch turns sharply, so the engine's turn test is relaxed
   to 89 degrees (``max_angle_deg``); its other checks of a step (the chord between the
   end tangents, the distance from the prediction) stay on;
3. checks from outside the branch: where it returns to the harmonic orbit against the
   period doubling D located by the scan, and the orbit a time simulation from rest
   settles on at w = 2.16 (entrainment) against the branch's orbit there, the verdict of
   each stable and unstable stretch against 400 revolutions of a time simulation started
   1e-6 off its middle orbit and, with ``--harmonic-balance``, the folds near F, where the
   bearing stays on its casing, against the converged harmonic balance (H = 120 of w/2)
   continued from the shooting orbit.

It prints the branch's folds, bifurcations and stable stretches, writes ``branch.csv``
(w, the +w/2 forward whirl radius of the disc, largest multiplier, stable, contact
switches in two revolutions) and ``special_points.csv`` (kind, w) and draws
``fig4_shooting.png`` in ``-o DIR``.

    python scripts/figures/rotor/rotor_subharmonic_shooting.py          # ~3 min on two cores
    python scripts/figures/rotor/rotor_subharmonic_shooting.py --harmonic-balance
                          # and the harmonic balance near F, ~3 min more
    python scripts/figures/rotor/rotor_subharmonic_shooting.py --quick  # the scan near F and a short stretch, ~20 s
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.timedomain.shooting import (ShootingOptions, ShootingProblem, ShootingStability, period_doubling_scan,
                             period_doubling_start, periodic_orbit)
from contin.timedomain.simulation import simulate
from contin.stability import orbit_state, stability_events
from contin.bifurcation.start import simulation_start

W0 = 2.16
# central differences of the flow map: independent of the variational equations (module docstring)
HARMONIC = ShootingOptions(steps_per_period=4096, jacobian="differences")
NU2 = ShootingOptions(steps_per_period=4096, subharmonic=2, jacobian="differences")
SPAN = (2.1, 2.25)


def engine_options(**kw) -> ContinuationOptions:
    """Steps of the rotor's shooting branch: the turn test relaxed for the grazing corners (module docstring)."""
    return ContinuationOptions(**{"ds": 0.01, "ds_max": 0.05, "newton_tol": 1e-9, "max_angle_deg": 89.0, **kw})


def orbit_info(model, w: float, z: np.ndarray, revolutions: int = 2) -> tuple[float, int]:
    """The +w/2 forward whirl radius of the disc and the number of contact switches on the orbit through ``z``.

    ``x1 + i y1 = F e^{i w t/2} + ...``; the radius is ``|F|``, by the mean over the
    ``revolutions * 4096`` RK4 steps of the orbit (the rectangle rule is exact for a
    trigonometric polynomial of the period).
    """
    n = model.n_dof
    run = simulate(model, {"w": w}, z[:n], z[n:], periods=revolutions, steps_per_period=4096, record_every=1)
    t, x = run.t[:-1], run.x[:-1]
    radius = float(abs(np.mean((x[:, 0] + 1j * x[:, 1]) * np.exp(-0.5j * w * t))))
    gap = np.hypot(x[:, 2], x[:, 3]) - model.parameter_vector({"w": w})[model.parameter_index("delta")]
    return radius, int(np.count_nonzero(np.diff(gap > 0)))


def same_orbit(model, w: float, a: np.ndarray, b: np.ndarray) -> float:
    """``max |a - b|`` up to the one-revolution shift of a period-2 orbit (both at ``w``)."""
    n = model.n_dof
    shifted = simulate(model, {"w": w}, a[:n], a[n:], periods=1, steps_per_period=4096).final_state
    return float(min(np.abs(a - b).max(), np.abs(shifted - b).max()))


def drift(model, w: float, z: np.ndarray, revolutions: int = 400, kick: float = 1e-6) -> float:
    """Distance from the orbit through ``z`` after ``revolutions`` of a time simulation started ``kick`` off it.

    Below ``kick`` the perturbation decayed (stable); far above it, it grew.
    """
    n = model.n_dof
    start = z + kick * np.eye(z.size)[0]
    end = simulate(model, {"w": w}, start[:n], start[n:], periods=revolutions, steps_per_period=4096).final_state
    return same_orbit(model, w, end, z)


def harmonic_period_doublings(model, grid, xtol: float = 1e-10):
    """The flow's period doublings on the harmonic orbit over ``grid`` (started from the harmonic balance),
    located to ``xtol`` in w."""
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024, crossings="none"))
    u0 = model.start(hb, float(grid[0]))
    return period_doubling_scan(model, {}, "w", grid, orbit_state(hb, u0, float(grid[0]), 0.0), HARMONIC, xtol=xtol)


def report(label: str, br, seconds: float) -> None:
    kinds = ("fold", "kink", "pd", "ns", "bp")
    marks = ", ".join(f"{sp.kind.value} {sp.parameter:.8f}" for sp in br.special_points if sp.kind.value in kinds)
    stable = np.asarray(br.point_data["stable"])
    runs = np.split(np.arange(len(br)), np.flatnonzero(np.diff(stable.astype(int))) + 1)
    intervals = [f"{br.parameter[r[0]]:.6f}..{br.parameter[r[-1]]:.6f}" for r in runs if r.size and stable[r[0]]]
    print(f"\n== {label}: {len(br)} points, w from {br.parameter.min():.6f} to {br.parameter.max():.6f} "
          f"[{seconds:.0f} s]")
    print(f"  folds, kinks and bifurcations: {marks or 'none'}")
    print(f"  stable stretches (between stored points): {', '.join(intervals) or 'none'}")
    print(f"  end: {br.status.value}: {br.message}")


def switched_branch(model, pd_orbit, options: ContinuationOptions, back_at: float = 0.02):
    """The nu = 2 branch born at a period doubling of the flow's harmonic orbit, until it returns to that orbit.

    Returns the branch and, per point, the +w/2 radius and contact switches (:func:`orbit_info`).
    The branch is shot as one segment of two revolutions (``segments=1``): with two segments of
    one revolution each the branch stalls at the grazing near w = 2.1964, with either Jacobian.
    The branch stops at the first point whose radius falls below ``back_at`` after exceeding
    ``10 back_at``: the other period doubling (beyond it the branch would retrace the same
    orbits shifted by one revolution).
    """
    t = time.perf_counter()
    w = pd_orbit.params["w"]
    doubled, u0, tangent = period_doubling_start(ShootingProblem(model, "w", options=HARMONIC), pd_orbit.state, w,
                                                 segments=1)
    mon = ShootingStability(doubled)
    info, grown = [], [False]

    def callback(br, i):
        while len(info) <= i:
            info.append(orbit_info(model, float(br.parameter[len(info)]), start_state(model, br.unknowns[len(info)])))
        grown[0] = grown[0] or info[-1][0] > 10 * back_at
        return not (grown[0] and info[-1][0] < back_at)

    br = continuation(doubled, u0, w, SPAN, options, parameter_name="w", monitors=[mon], events=stability_events(mon),
                      tangent=tangent, solve_start=False, callback=callback)
    report(f"switched at the period doubling w = {w:.8f}", br, time.perf_counter() - t)
    return br, info[:len(br)]


def start_state(model, u: np.ndarray) -> np.ndarray:
    """The orbit's state ``(x, x')`` at ``t = 0`` from a branch point's unknowns (its first segment's start)."""
    return np.asarray(u[:2 * model.n_dof], dtype=float)


def entrained_orbit(model, revolutions: int = 1500):
    """The period-2 orbit through the state a time simulation from rest reaches at ``W0``."""
    run = simulate(model, {"w": W0}, periods=revolutions, steps_per_period=4096, record_every=4096)
    return periodic_orbit(model, {"w": W0}, run.final_state, NU2)


def harmonic_balance_near_f(model, br, index: int = 4, harmonics: int = 120) -> None:
    """The converged harmonic balance's branch from the shooting orbit ``br[index]``, towards lower w.

    Near F the bearing stays on its casing, where the plainly sampled contact law is smooth and
    ``harmonics`` of w/2 converge; prints its folds beside the shooting branch's in the same range.
    """
    t = time.perf_counter()
    n = model.n_dof
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=harmonics, subharmonic=2, samples=2048, crossings="none"))
    w, z = float(br.parameter[index]), start_state(model, br.unknowns[index])
    u = simulation_start(hb, w, transient=2, x0=z[:n], v0=z[n:])
    hbr = continuation(hb, u, w, (2.19, 2.21), ContinuationOptions(ds=0.005, ds_max=0.02, newton_tol=1e-9,
                                                                   direction=-1, max_points=300), parameter_name="w")
    lo = float(hbr.parameter.min())
    folds = [p.parameter for p in hbr.points_of_kind("fold")]
    mine = [p.parameter for p in br.points_of_kind("fold") if p.parameter >= lo]
    print(f"\n== harmonic balance, H = {harmonics} of w/2, from the shooting orbit at w = {w:.6f}: {len(hbr)} points "
          f"down to w = {lo:.8f} [{time.perf_counter() - t:.0f} s]\n  end: {hbr.status.value}: {hbr.message}")
    print(f"  its folds:      {', '.join(f'{f:.8f}' for f in folds)}")
    print(f"  shooting folds: {', '.join(f'{f:.8f}' for f in mine)}")


def rows_of(br, info) -> list[dict]:
    mu = np.asarray(br.point_data["max_multiplier"])
    return [{"w": float(br.parameter[i]), "radius": info[i][0], "max_multiplier": float(mu[i]),
             "stable": bool(br.point_data["stable"][i]), "contact_switches": info[i][1]} for i in range(len(br))]


def draw_stability(ax, w, y, stable, label=None, **style) -> None:
    """``y`` against ``w``, solid where ``stable``, dashed elsewhere; each change drawn from the last point before it."""
    w, y, stable = np.asarray(w), np.asarray(y), np.asarray(stable, dtype=bool)
    for k, s in enumerate(np.split(np.arange(len(w)), np.flatnonzero(np.diff(stable.astype(int))) + 1)):
        if s.size:
            i = np.arange(max(s[0] - 1, 0), s[-1] + 1)
            ax.plot(w[i], y[i], "-" if stable[s[0]] else "--", label=label if k == 0 else None, **style)


def draw(rows, pds, harmonic, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0), constrained_layout=True)
    draw_stability(ax, [r["w"] for r in rows], [r["radius"] for r in rows], [r["stable"] for r in rows],
                   color="k", lw=1.2)
    ax.plot([], [], "-", color="k", label="1/2-subharmonic branch, stable")
    ax.plot([], [], "--", color="k", label="unstable")
    draw_stability(ax, [h[0] for h in harmonic], np.zeros(len(harmonic)), [h[1] for h in harmonic],
                   color="0.5", lw=1.0)
    ax.plot([], [], "--", color="0.5", label="harmonic orbit of the flow (zero +w/2)")
    ax.plot(pds, np.zeros(len(pds)), "o", color="C3", ms=5, label="its period doublings (scan)")
    ax.set_xlabel(r"rotor speed $\Omega$")
    ax.set_ylabel(r"forward whirl radius of the disc at $\Omega/2$")
    ax.set_title(r"bearing rotor, $f_0$ = 0.5, equations of motion (shooting): stable solid, unstable dashed")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def fig4_branches(model, quick: bool, harmonic_balance: bool = False):
    """The equations of motion's nu = 2 branch from F.

    Returns ``(rows, [w of the period doublings], [(w, stable) of the scan's harmonic orbits],
    [special points of the branch])``.
    """
    grid = np.linspace(2.200, 2.212, 3) if quick else np.linspace(2.12, 2.22, 21)
    t = time.perf_counter()
    scan = harmonic_period_doublings(model, grid, 1e-6 if quick else 1e-10)
    pds = sorted(scan.points, key=lambda o: o.params["w"])
    found = ", ".join(f"{o.params['w']:.8f}" for o in pds) or "none"
    print(f"period doublings of the flow's harmonic orbit on w = {grid[0]:g}..{grid[-1]:g}: {found} ({scan.status}) "
          f"[{time.perf_counter() - t:.0f} s]")
    if not pds:
        raise SystemExit("no period doubling found")
    br, info = switched_branch(model, pds[-1], engine_options(max_points=4 if quick else 600))
    rows = rows_of(br, info)
    special = [{"kind": sp.kind.value, "w": float(sp.parameter)} for sp in br.special_points]
    out = rows, [o.params["w"] for o in pds], [(o.params["w"], o.stable) for o in scan.orbits], special
    if quick:
        return out
    if len(pds) > 1 and rows[-1]["radius"] < 0.02:
        print(f"  back on the harmonic orbit at w = {br.parameter[-1]:.8f}; the scan's period doubling D is at "
              f"{pds[0].params['w']:.8f} ({abs(br.parameter[-1] - pds[0].params['w']):.1e} apart)")
    t = time.perf_counter()
    orb = entrained_orbit(model)
    first = next((i for i in range(1, len(br)) if (br.parameter[i - 1] - W0) * (br.parameter[i] - W0) <= 0), None)
    if orb.converged and first is not None:
        on_branch = periodic_orbit(model, {"w": W0}, start_state(model, br.unknowns[first]), NU2)
        gap = same_orbit(model, W0, orb.state, on_branch.state)
        print(f"  a time simulation from rest at w = {W0} settles on an orbit {gap:.1e} from the branch's "
              f"(stable: {on_branch.stable}; {time.perf_counter() - t:.0f} s)")
    if harmonic_balance:
        harmonic_balance_near_f(model, br)
    # the verdicts checked by time integration: the middle point of each stretch, kicked by 1e-6
    stable = np.asarray(br.point_data["stable"])
    for r in np.split(np.arange(len(br)), np.flatnonzero(np.diff(stable.astype(int))) + 1):
        if r.size >= 3:
            i = int(r[r.size // 2])
            print(f"  w = {br.parameter[i]:.6f} ({'stable' if stable[i] else 'unstable'}, largest multiplier "
                  f"{br.point_data['max_multiplier'][i]:.4f}): 400 revolutions from 1e-6 off the orbit end "
                  f"{drift(model, float(br.parameter[i]), start_state(model, br.unknowns[i])):.1e} from it")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the scan near F and a short stretch of its branch")
    ap.add_argument("--harmonic-balance", action="store_true",
                    help="also continue the harmonic balance (H = 120 of w/2) from the branch near F, ~3 min more")
    ap.add_argument("-o", "--outdir", default="results/rotor_fig4_shooting")
    args = ap.parse_args(argv)
    limit_blas_threads(1)
    out = Path(args.outdir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    model = build_model("bearing_rotor", {"f0": 0.5})
    rows, pds, harmonic, special = fig4_branches(model, args.quick, args.harmonic_balance)
    for name, table in (("branch.csv", rows), ("special_points.csv", special)):
        with open(out / name, "w", newline="") as fh:
            wr = csv.DictWriter(fh, fieldnames=list(table[0]))
            wr.writeheader()
            wr.writerows(table)
    draw(rows, pds, harmonic, out / "fig4_shooting.png")
    print(f"\ntotal {time.perf_counter() - t0:.1f} s; {out / 'branch.csv'}, {out / 'fig4_shooting.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
