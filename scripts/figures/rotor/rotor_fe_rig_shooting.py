"""The finite-element rig's harmonic branch by shooting, and its period doublings (docs/validation/fe-rotor.md).

The rig of ``scenes/rotor_fe_rig.yaml`` (Craig-Bampton, 8 modes, 12 dofs) on its integrated flow
(:class:`contin.timedomain.shooting.ShootingProblem`, one segment, 4096 RK4 steps a revolution, the
contact switches located, multipliers by periodic Schur of the variational factors):

1. the harmonic orbit at ``w = 2.4`` by Newton from the harmonic balance's state (H = 20, the scene's);
2. the harmonic branch of the flow continued from there both ways over ``[2.16, 2.45]`` with the
   stability events (folds, period doublings, Neimark-Sacker points); the turn test relaxed to 89
   degrees for the grazing corners, as in ``rotor_subharmonic_shooting.py``;
3. at every period doubling the branch reports, the switch to ``nu = 2``
   (:func:`contin.timedomain.shooting_bifurcations.period_doubling_start`), and Newton on the ``nu = 2``
   problem from the orbit pushed along the eigenvector of its real multiplier below -1.

It prints the branch's special points, the multipliers nearest -1 at the harmonic balance's period
doublings (2.4018 to 2.4282), the switch's outcome, and draws ``rotor_fe_rig_shooting.png`` in ``-o DIR``
(the disc's forward whirl at ``w``, the largest multiplier and the distance of the multipliers to -1).

4. with ``--simulation``: a run-up of time simulations (RK4, 4096 steps a revolution, 400 revolutions per
   speed from the last state of the one before, from rest at ``w = 1.90``) through the speeds where the
   up sweep of ``rotor_fe_rig.py`` entrains into ``+w/2``, printing how far the state moves from one
   revolution to the next over the last 20 and the disc's whirl components over 64 more revolutions.

    python scripts/figures/rotor/rotor_fe_rig_shooting.py -o docs/figures     # ~10 min on two cores
    python scripts/figures/rotor/rotor_fe_rig_shooting.py --simulation        # the run-up alone, ~2 min
    python scripts/figures/rotor/rotor_fe_rig_shooting.py --quick             # the RK4 step bound alone (CI)
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.output.figures import figure_style, new_figure, save_figure
from contin.scene.build import build_model
from contin.scene.parse import load_scene
from contin.stability import orbit_state, stability_events
from contin.timedomain.integrator import RK4_STABILITY, compile_model
from contin.timedomain.shooting_bifurcations import ShootingStability, period_doubling_start
from contin.timedomain.shooting import ShootingOptions, ShootingProblem
from contin.timedomain.simulation import simulate
from contin.util.blas import limit_blas_threads

ROOT = Path(__file__).resolve().parents[3]
SCENE = ROOT / "scenes" / "rotor_fe_rig.yaml"
W0, SPAN = 2.4, (2.16, 2.45)
#: the harmonic balance's period doublings (H = 20) near w = 2.4: the first and the last
HB_PD = (2.4018, 2.4282)


def newton(problem, u, w, tol=1e-10, iterations=15):
    """Plain Newton on ``problem`` at fixed ``w``: the unknowns and the last residual (max norm)."""
    for _ in range(iterations):
        R, J, _ = problem.linearize(u, w)
        if np.abs(R).max() < tol:
            break
        u = u + np.linalg.solve(J, -R)
    return u, float(np.abs(problem.residual(u, w)).max())


def whirl(problem, u, w) -> float:
    """The disc's forward whirl radius at ``w``: ``|mean((x_11 + i y_11) e^{-i w t})|`` over the step grid."""
    model = problem.model
    t = np.arange(4096) * problem.period_at(w) / 4096
    x, _ = problem.orbit(u, w, t)
    z = x[model.dof_index("x_11")] + 1j * x[model.dof_index("y_11")]
    return float(abs(np.mean(z * np.exp(-1j * w * t))))


def run_up(model, speeds=(1.90, 1.94, 1.96, 1.97, 1.975, 1.98, 1.985, 1.99, 1.995, 2.0), S=4096):
    """Item 4 of the module docstring."""
    n = model.n_dof
    x0 = v0 = None
    for w in speeds:
        run = simulate(model, {"w": w}, x0, v0, periods=400, steps_per_period=S, record_every=S)
        x0, v0 = run.final_state[:n], run.final_state[n:]
        spread = np.abs(np.diff(run.x[-21:], axis=0)).max()
        tail = simulate(model, {"w": w}, x0, v0, periods=64, steps_per_period=S, record_every=16)
        t, x = tail.t[:-1], tail.x[:-1]
        c = x[:, model.dof_index("x_11")] + 1j * x[:, model.dof_index("y_11")]
        F = np.fft.fft(c) / len(t)
        order = np.fft.fftfreq(len(t), d=t[1] - t[0]) * 2 * np.pi / w  # in multiples of w
        top = np.argsort(-np.abs(F))[:5]
        lines = ", ".join(f"{order[i]:+.4f} w: {abs(F[i]):.4f}" for i in top)
        print(f"w = {w:.4f}: largest change of x from one revolution to the next (last 20) {spread:.1e}; "
              f"disc whirl components {lines}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--outdir", default=".")
    ap.add_argument("--simulation", action="store_true", help="the run-up of time simulations alone (item 4)")
    ap.add_argument("--quick", action="store_true", help="the RK4 step bound of the rig alone (CI)")
    args = ap.parse_args(argv)
    limit_blas_threads(1)
    out = Path(args.outdir)
    out.mkdir(parents=True, exist_ok=True)
    model = build_model(load_scene(SCENE))
    if args.simulation:
        run_up(model)
        return
    if args.quick:  # the fewest RK4 steps a revolution the rig's stiffest mode allows, at both ends of the span
        cm = compile_model(model)
        for w in SPAN:
            rate = cm.fastest_rate(model.parameter_vector({"w": w}))
            print(f"w = {w}: RK4 needs at least {rate * 2 * np.pi / w / RK4_STABILITY:.0f} steps a revolution")
        return
    steps = 4096  # fewer and Newton from the truncated series diverges (1024: residual 1e3)
    problem = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=steps, segments=1))
    mon = ShootingStability(problem)

    hb = HarmonicBalance(model, "w", HBOptions(harmonics=20, samples=512, crossings="interval"))
    u0 = problem.start_unknowns(orbit_state(hb, model.start(hb, W0), W0, 0.0), W0)
    print(f"harmonic balance (H = 20) in the flow at w = {W0}: residual {np.abs(problem.residual(u0, W0)).max():.2e}")
    u0, r = newton(problem, u0, W0)
    print(f"shooting orbit at w = {W0} ({steps} steps a revolution): residual {r:.1e}, multipliers "
          f"{np.round(problem.multipliers(u0, W0)[:4], 4)}")

    rows, special, orbits = [], [], []
    for direction, cap in ((-1, 260), (+1, 250)):
        t = time.perf_counter()
        # ds_min: a grazing corner that Newton cannot pass ends the branch within seconds, not minutes
        opts = ContinuationOptions(ds=0.002, ds_max=0.005, ds_min=1e-6, newton_tol=1e-9, max_angle_deg=89.0,
                                   direction=direction, max_points=cap)
        br = continuation(problem, u0, W0, SPAN, opts, parameter_name="w", monitors=[mon], events=stability_events(mon))
        print(f"\nbranch {'down' if direction < 0 else 'up'}: {len(br)} points, w {br.parameter.min():.5f} to "
              f"{br.parameter.max():.5f}, {br.status.value}: {br.message} [{time.perf_counter() - t:.0f} s]")
        for sp in br.special_points:
            if sp.kind.value in ("fold", "pd", "ns", "bp"):
                mu = problem.multipliers(sp.unknowns, sp.parameter)
                near = mu[np.argsort(np.abs(mu + 1.0))[:2]]
                print(f"  {sp.kind.value} w = {sp.parameter:.6f} (located: {sp.located}); nearest -1: "
                      f"{np.round(near, 4)}; largest: {np.round(mu[0], 4)}")
                special.append(sp)
        for i in range(len(br)):
            w, u = float(br.parameter[i]), br.unknowns[i]
            mu = problem.multipliers(u, w)
            real = mu[np.abs(mu.imag) < 1e-9].real
            rows.append((w, whirl(problem, u, w), float(np.abs(mu).max()), float(np.abs(mu + 1.0).min()),
                         float(np.abs(real + 1.0).min()) if real.size else np.inf,
                         float(real.min()) if real.size else np.inf))
            orbits.append((w, np.asarray(u)))
    order = np.argsort([r[0] for r in rows], kind="stable")
    rows, orbits = [rows[i] for i in order], [orbits[i] for i in order]
    W = np.array([r[0] for r in rows])
    for w in HB_PD:
        i = int(np.argmin(np.abs(W - w)))
        print(f"at the harmonic balance's period doubling w = {w}: flow point w = {W[i]:.5f}, "
              f"min |mu + 1| = {rows[i][3]:.3f} (real multipliers: {rows[i][4]:.3f})")

    print("\nswitching to nu = 2:")
    doubled = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=4096, subharmonic=2, segments=1))
    for sp in special:
        if sp.kind.value != "pd":
            continue
        for eps in (1e-3, 1e-4):
            try:
                pd2, v0, tangent = period_doubling_start(problem, sp.unknowns, sp.parameter, eps=eps)
            except ValueError as exc:
                print(f"  pd {sp.parameter:.6f}: {exc}")
                break
            report_nu2(problem, pd2, v0, sp.parameter, f"pd {sp.parameter:.6f}, offset {eps:g}")
            # ds_min: refused steps at a grazing orbit end the attempt within a minute
            opts = ContinuationOptions(ds=1e-3, ds_max=5e-3, ds_min=1e-5, newton_tol=1e-9, newton_max_iter=8,
                                       max_angle_deg=89.0, max_points=10)
            br = continuation(pd2, v0, sp.parameter, SPAN, opts, parameter_name="w", tangent=tangent,
                              solve_start=False)
            print(f"    continued: {len(br)} points, {br.status.value}: {br.message}")
    # the stored orbits with a real multiplier below -1 (between the sign changes of det(Phi + I))
    for w, u in [(w, u) for (w, u), r in zip(orbits, rows) if r[4] < np.inf and r[5] < -1.0][:2]:
        mu, V = np.linalg.eig(_monodromy(problem, u, w))
        j = int(np.argmin(mu.real))
        v = np.real(V[:, j]) / np.linalg.norm(np.real(V[:, j]))
        for eps in (1e-2, 3e-2, 1e-1):
            report_nu2(problem, doubled, doubled.start_unknowns(u + eps * v, w), w,
                       f"w = {w:.6f}, the orbit + {eps:g} v (v of its multiplier {mu[j].real:.3f})")

    with figure_style():
        fig = new_figure(figsize=(6.4, 6.4))
        ax = fig.subplots(3, 1, sharex=True)
        R = np.array(rows)
        ax[0].plot(R[:, 0], R[:, 1], "k.", ms=2)
        ax[0].set_ylabel("disc whirl at $w$")
        ax[1].plot(R[:, 0], R[:, 2], "k.", ms=2)
        ax[1].axhline(1.0, color="0.6", lw=0.8)
        ax[1].set_ylabel(r"largest $|\mu|$")
        ax[2].plot(R[:, 0], R[:, 3], "k.", ms=2, label=r"min $|\mu + 1|$, all multipliers")
        ax[2].plot(R[:, 0], np.minimum(R[:, 4], 2.0), "r.", ms=2, label=r"min $|\mu + 1|$, real ones (2: none)")
        ax[2].set_ylim(0, 2.05)
        ax[2].set_ylabel(r"distance to $-1$")
        ax[2].set_xlabel(r"rotor speed $w$ (rig units)")
        for a in ax:
            a.axvspan(*HB_PD, color="tab:orange", alpha=0.2, lw=0)
            for sp in special:
                if sp.kind.value == "pd":
                    a.axvline(sp.parameter, color="tab:red", lw=0.6, ls=":")
        ax[2].legend(fontsize=7, loc="upper right")
        ax[0].set_title("rig (8 modes), harmonic orbit by shooting; shaded: the harmonic balance's period doublings",
                        fontsize=8)
        save_figure(fig, out / "rotor_fe_rig_shooting.png")
    print(f"wrote {out / 'rotor_fe_rig_shooting.png'}")


def report_nu2(problem, doubled, u, w, label):
    """Newton on the ``nu = 2`` problem at fixed ``w`` from ``u``; prints the residual and, converged, how far
    the orbit is from closing after one revolution (0: the harmonic orbit), its largest multiplier and graze."""
    try:
        u, r = newton(doubled, u, w)
    except ArithmeticError as exc:
        print(f"  nu = 2 Newton, {label}: {exc}")
        return
    text = f"  nu = 2 Newton, {label}: residual {r:.1e}"
    if r < 1e-9:
        z = u[:2 * problem.n]
        text += (f"; max |phi_T(z) - z| = {np.abs(problem.residual(z, w)).max():.1e}, largest |mu| "
                 f"{np.abs(doubled.multipliers(u, w)).max():.4f}, graze {doubled.graze(u, w)[0]:.1e}")
    print(text)


def _monodromy(problem, u, w):
    Phi = np.eye(2 * problem.n)
    for F in problem.factors(u, w):
        Phi = F @ Phi
    return Phi


if __name__ == "__main__":
    main()
