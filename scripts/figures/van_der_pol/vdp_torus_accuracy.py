"""Accuracy of the quasi-periodic harmonic balance against the harmonic counts H1 and H2 (forced van der Pol).

x'' - mu (1 - x^2) x' + x = F cos(w t), mu = 0.1, F = 0.15, at w = 0.94 (quasi-periodic, near the
entrainment boundary w = 0.951). For each truncation the torus is solved (continued from its
Neimark-Sacker point) and compared with an independent time integration (scipy DOP853, rtol 1e-11)
started on it: the error is the largest distance of the simulated state (x, x') to the torus over
150 forcing periods, relative to the torus' RMS state size (contin.timedomain.torus_check.torus_distance).
Three families: H1 = H2 = H; H1 = 12 with H2 = H; H2 = 12 with H1 = H. The script prints the table
and the fitted exponential rate of the error against H, and draws the figure of the accuracy document.

    python scripts/figures/van_der_pol/vdp_torus_accuracy.py [-o DIR] [--quick]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from contin.api.system import System
from contin.bifurcation.diagram import follow
from contin.bifurcation.torus_start import torus_start
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import TorusOptions
from contin.output.figures import new_figure, save_figure
from contin.timedomain.torus_check import torus_distance

MU, F, W = 0.1, 0.15, 0.94


def model():
    return System(dofs=["x"], parameters={"mu": MU, "F": F, "w": 0.8}, mass=[[1]], damping=[["-mu"]],
                  stiffness=[[1]], forces=[{"dof": "x", "expr": "mu*x**2*x_dot"}],
                  excitation=[{"dof": "x", "expr": "F*cos(tau)"}], frequency="w").model


def periodic_branch():
    """The periodic branch through the entrainment boundary, with its Neimark-Sacker point."""
    hb = HarmonicBalance(model(), "w", HBOptions(5))
    br = follow(hb, hb.linear_solution(W), W, (W, 0.97), {"ds": 0.02}, stability={"method": "hill"},
                switch=())[0]
    return hb, br, next(sp for sp in br.special_points if sp.kind.value == "ns")


def torus_at(start, H1: int, H2: int):
    """The torus of truncation (H1, H2) at w = W: continued from the NS point to the end of the range."""
    hb, br, ns = start
    st = torus_start(hb, br, ns, TorusOptions(H1, H2))
    tb = continuation(st.problem, st.u, st.lam, (W, 0.97), ContinuationOptions(ds=0.02), tangent=st.tangent,
                      solve_start=False, parameter_name="w")
    assert tb.parameter[-1] == W, tb.message
    return st.problem, tb.unknowns[-1], W


def error(qp, u, lam: float, periods: float) -> float:
    x0, v0 = qp.state_at(u, lam, np.zeros(1))
    t = np.linspace(0.0, periods * 2 * math.pi / lam, 601)
    sol = solve_ivp(lambda t, y: [y[1], MU * (1 - y[0] ** 2) * y[1] - y[0] + F * math.cos(lam * t)],
                    (0.0, t[-1]), [x0[0, 0], v0[0, 0]], t_eval=t, method="DOP853", rtol=1e-11, atol=1e-12)
    return float(np.max(torus_distance(qp, u, lam, t, sol.y.T)))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--outdir", default=".")
    ap.add_argument("--quick", action="store_true", help="two truncations, a short record (for CI)")
    a = ap.parse_args(argv)
    Hs = [3, 4] if a.quick else [2, 3, 4, 6, 8, 10, 12]
    periods = 20 if a.quick else 150
    top = 4 if a.quick else 12
    start = periodic_branch()
    rows = {"H1 = H2 = H": [], f"H1 = {top}, H2 = H": [], f"H1 = H, H2 = {top}": []}
    if a.quick:  # one family
        rows = {"H1 = H2 = H": []}
    for H in Hs:
        for name, (h1, h2) in zip(rows, ((H, H), (top, H), (H, top))):  # zip stops at the families kept
            qp, u, lam = torus_at(start, h1, h2)
            e = error(qp, u, lam, periods)
            rows[name].append(e)
            print(f"{name:16s} H={H:2d}  (H1, H2) = ({h1:2d}, {h2:2d})  w = {lam:.6f}  w2 = {u[-1]:.8f}  "
                  f"error {e:.3e}")
    for name, es in rows.items():
        rate = np.polyfit(Hs, np.log(es), 1)[0]
        print(f"{name}: error falls by a factor {math.exp(-rate):.2f} per harmonic (fitted over H = {Hs})")
    fig = new_figure((6.0, 3.8))
    ax = fig.add_subplot()
    for (name, es), m in zip(rows.items(), "os^"):
        ax.semilogy(Hs, es, marker=m, label=f"${name.replace('H1', 'H_1').replace('H2', 'H_2')}$")
    ax.set_xlabel("harmonics $H$")
    ax.set_ylabel("distance of the simulated motion\nto the torus / torus size")
    ax.set_title(rf"forced van der Pol, $\mu$ = {MU}, $F$ = {F}, $\Omega$ = {W}")
    ax.legend(loc="upper right")
    ax.grid(True, which="both", alpha=0.3)
    Path(a.outdir).mkdir(parents=True, exist_ok=True)
    names = save_figure(fig, Path(a.outdir) / "accuracy_torus_vdp", ["png"], 150)
    print("wrote", ", ".join(names))


if __name__ == "__main__":
    main()
