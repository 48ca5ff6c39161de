"""The seed-001 test rig as a finite-element rotor (ROSS) against the paper's reduced model (eq. 11).

Two comparisons, written to ``OUTDIR``:

1. **Natural frequencies** (``rotor_fe_campbell.png``, and a table printed in Markdown): the lowest forward and
   backward whirl frequencies against the rotor speed of

   - the reduced model (:mod:`contin.models.bearing_rotor`, the paper's ``ip = 0.1``, ``beta``, ``alpha``,
     ``ks2``), scaled back to SI by the paper's ``wn = sqrt(ks1/m1)``;
   - the finite-element rotor (``scenes/data/rig_001.npz``, 76 lateral dofs) and its Craig-Bampton reduction
     with 8 modes (the model the rig scene integrates for stability),

   with the lower bearing held (a spring ``kbn`` both ways) and pressed on its casing by the side load
   (``kbn`` radially, ``Fn/delta`` tangentially: the contact's stiffness about the pressed state).
2. **Speed sweeps** (``rotor_fe_sweep.png``): the disc's whirl components along an up sweep of time
   simulations (:func:`contin.timedomain.whirl_sweep.component_sweep`) of both models at the paper's
   Fig. 3 values, ``f0 = 0.5``.

    python scripts/figures/rotor/rotor_fe_rig.py [--quick] [-o OUTDIR]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from contin.model.catalog import build_model
from contin.model.fem.builder import Reduction, Units, fe_rotor_model
from contin.model.fem.matrices import load_matrices
from contin.model.fem.rig import RIG, RIG_NODES, rig_items, rig_scales
from contin.output.figures import figure_style, new_figure, save_figure
from contin.timedomain.whirl_sweep import component_sweep
from contin.util.blas import limit_blas_threads

ROOT = Path(__file__).resolve().parents[3]
RIG_FILE = ROOT / "scenes" / "data" / "rig_001.npz"
#: rotor speeds [rad/s] of the natural-frequency table
TABLE_SPEEDS = (0.0, 80.0, 160.0, 240.0)


def _lowest_pair(M, C, K):
    """The two lowest damped natural frequencies [rad/s] of ``M x'' + C x' + K x = 0``.

    At rest they are the two planar modes of the lowest pair (split when the bearing is pressed on one
    side); with speed the gyroscopic terms turn them into a forward (upper) and a backward (lower) whirl.
    """
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    s = np.linalg.eigvals(A)
    return np.sort(s.imag[s.imag > 1e-6])[:2]


def _held(K, dofs, k_radial, k_tangential):
    K = K.copy()
    K[dofs[0], dofs[0]] += k_tangential  # the side load presses along +y: x is tangential
    K[dofs[1], dofs[1]] += k_radial
    return K


def natural_frequencies(speeds, modes: int = 8) -> dict:
    """The lowest pair of natural frequencies [Hz] of the three models at ``speeds`` [rad/s].

    Returns
    -------
    dict
        ``(model, condition) -> (upper (len(speeds),), lower (len(speeds),))``; models ``reduced``,
        ``fe``, ``fe_cb``; conditions ``held``, ``pressed``. With speed the upper one is the forward whirl.
    """
    s = rig_scales()
    wn, ks1 = s["wn"], s["ks1"]
    kbn = RIG["kbn"] * ks1
    fn = RIG["f0"] * ks1 * s["d0"] * RIG["a"] / RIG["length"]  # the bearing's share of the side load [N]
    conditions = {"held": (kbn, kbn), "pressed": (kbn, fn / (RIG["delta"] * s["d0"]))}
    reduced = build_model("bearing_rotor", effects=("gyroscopic", "disc_damping", "bearing_damping"))
    rotor = load_matrices(RIG_FILE)
    lower = rotor.node_dofs(RIG_NODES["lower"])
    items = rig_items()
    cb = fe_rotor_model(rotor, **items, units=Units(1.0, 1.0, 1.0), reduction=Reduction(modes))  # SI
    out = {}
    for cond, (kr, kt) in conditions.items():
        rows = {"reduced": [], "fe": [], "fe_cb": []}
        for W in speeds:
            M, C, K = reduced.linear(reduced.parameter_vector({"w": W / wn}))
            rows["reduced"].append(wn * _lowest_pair(M, C, _held(K, (2, 3), kr / ks1, kt / ks1)))
            M, C, K = rotor.linear(W)
            rows["fe"].append(_lowest_pair(M, C, _held(K, lower, kr, kt)))
            M, C, K = cb.linear(cb.parameter_vector({"w": W}))
            rows["fe_cb"].append(_lowest_pair(M, C, _held(K, (0, 1), kr, kt)))
        for name, r in rows.items():
            r = np.array(r) / (2 * np.pi)
            out[(name, cond)] = (r[:, 1], r[:, 0])
    return out


def table(freqs: dict, speeds) -> str:
    """The Markdown table of :func:`natural_frequencies`."""
    head = "| bearing | model | " + " | ".join(f"{W:g} rad/s [Hz]" for W in speeds) + " |"
    lines = [head, "|" + " --- |" * (2 + len(speeds))]
    names = {"reduced": "reduced (eq. 11)", "fe": "finite elements", "fe_cb": "Craig-Bampton, 8 modes"}
    for (name, cond), (f, b) in freqs.items():
        lines.append(f"| {cond} | {names[name]} | " + " | ".join(f"{y:.2f}, {x:.2f}" for x, y in zip(f, b)) + " |")
    return "\n".join(lines)


def sweeps(speeds, transient: float, record: int, steps: int) -> dict:
    """Up sweeps of the reduced model and the rig (Craig-Bampton, 8 modes) at the paper's Fig. 3 values.

    The rig's speed is scaled by its own lowest frequency with the bearing held (``w0``), the reduced model's
    by the paper's ``wn``; both sweeps run over the same rotor speeds in rad/s, given as ``speeds`` in units
    of ``wn``.
    """
    s = rig_scales()
    reduced = build_model("bearing_rotor", {"f0": 0.5})
    rig = fe_rotor_model(load_matrices(RIG_FILE), **rig_items(), reduction=Reduction(8))
    w0 = rig.fe.units.frequency
    out = {}
    for name, model, scale, dofs in (("reduced", reduced, 1.0, (0, 1)),
                                     ("fe", rig, s["wn"] / w0, (rig.dof_index("x_11"), rig.dof_index("y_11")))):
        from contin.timedomain.whirl_sweep import WhirlOptions

        t = time.perf_counter()
        out[name] = component_sweep(model, None, np.asarray(speeds) * scale, transient_periods=transient,
                                    record_periods=record, steps_per_period=steps,
                                    options=WhirlOptions(dofs=dofs))
        print(f"sweep {name}: {len(speeds)} speeds, {time.perf_counter() - t:.1f} s")
    return out


def hb_branches() -> dict:
    """Harmonic (nu = 1) branches of the rig scene from several starts: ``w -> disc whirl radius`` by branch.

    Each ends where the bearing starts to bounce (a grazing point the truncated series cannot pass).
    """
    from contin.api import run

    res = run(ROOT / "scenes" / "rotor_fe_rig.yaml",
              overrides=["analysis.starts=[{start: 2.4, both_ways: true}, {start: 2.6}]"])
    out = {b.id: (np.asarray(b.parameter), np.asarray(b["whirl_fwd_1_disc"])) for b in res.branches}
    print("harmonic branches:", "; ".join(f"w {w.min():.4f} to {w.max():.4f}" for w, _ in out.values()))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--outdir", default=".")
    ap.add_argument("--quick", action="store_true", help="few speeds and short runs (CI)")
    args = ap.parse_args(argv)
    limit_blas_threads(1)
    out = Path(args.outdir)
    out.mkdir(parents=True, exist_ok=True)
    wn = rig_scales()["wn"]
    grid = np.linspace(0.0, 2.6 * wn, 12 if args.quick else 105)
    freqs = natural_frequencies(grid)
    print(table(natural_frequencies(TABLE_SPEEDS), TABLE_SPEEDS))
    with figure_style():
        fig = new_figure(figsize=(6.4, 4.6))
        ax = fig.subplots()
        colors = {"reduced": "tab:blue", "fe": "tab:red", "fe_cb": "k"}
        labels = {"reduced": "reduced model (eq. 11)", "fe": "finite elements (ROSS)", "fe_cb": "Craig-Bampton, 8 modes"}
        for (name, cond), (f, b) in freqs.items():
            ls = "-" if cond == "pressed" else "--"
            # the reduction lies on the full model's curves: drawn thin over them
            style = {"color": colors[name], "ls": ls, "lw": {"reduced": 1.2, "fe": 2.6, "fe_cb": 0.7}[name],
                     "alpha": 0.5 if name == "fe" else 1.0}
            ax.plot(grid, f, label=f"{labels[name]}, bearing {cond}", **style)
            ax.plot(grid, b, **style)
        ax.plot(grid, grid / (2 * np.pi), color="0.6", lw=0.8, label=r"$\Omega$")
        ax.plot(grid, grid / (4 * np.pi), color="0.6", lw=0.8, ls=":", label=r"$\Omega/2$")
        ax.set_xlabel(r"rotor speed $\Omega$ [rad/s]")
        ax.set_ylabel("natural frequency [Hz]")
        ax.set_ylim(8, 18)
        ax.set_xlim(0, grid[-1])
        ax.legend(fontsize=7, loc="upper left", ncol=2)
        ax.set_title("test rig: the lowest pair of natural frequencies")
        save_figure(fig, out / "rotor_fe_campbell.png")
    branches = {}
    if args.quick:
        sw = sweeps([1.9, 2.1], 60.0, 30, 2048)
    else:
        sw = sweeps(np.round(np.arange(1.5, 2.601, 0.02), 3), 400.0, 200, 4096)
        branches = hb_branches()
    for name in sw:
        print(f"{name}: Omega/2 meets the upper frequency (pressed) at {subharmonic_speed(freqs, grid, name):.1f} rad/s")
    with figure_style():
        fig = new_figure(figsize=(9.6, 3.8))
        axes = fig.subplots(1, 2, sharey=True, sharex=True)
        for ax, (name, res) in zip(axes, sw.items()):
            W = np.asarray(res.w) * (wn if name == "reduced" else rig_fe_w0())
            for attr, color, text in (("forced", "tab:blue", r"$+\Omega$"), ("subharmonic", "tab:red", r"$+\Omega/2$"),
                                      ("self_excited", "tab:green", r"self-excited $p_f$")):
                ax.plot(W, getattr(res, attr), "o-", color=color, ms=3, lw=0.8, label=text)
            if name == "fe":
                for i, (w, r) in enumerate(branches.values()):
                    ax.plot(w * rig_fe_w0(), r, "k-", lw=2.0,
                            label="harmonic balance, $\\nu$ = 1 (to grazing)" if i == 0 else None)
            W2 = subharmonic_speed(freqs, grid, name)
            ax.axvline(W2, color="tab:red", lw=0.8, ls=":", label=r"$\Omega/2$ = upper natural frequency (pressed)")
            ax.set_xlabel(r"rotor speed $\Omega$ [rad/s]")
            ax.set_title("reduced model (eq. 11)" if name == "reduced" else "finite-element rig (8 modes)")
        axes[0].set_ylabel("whirl radius of the disc [mm]")
        axes[0].legend(fontsize=8)
        if branches:
            axes[1].legend(fontsize=8, loc="upper right")
        save_figure(fig, out / "rotor_fe_sweep.png")
    print(f"wrote {out / 'rotor_fe_campbell.png'}, {out / 'rotor_fe_sweep.png'}")


def subharmonic_speed(freqs: dict, grid, name: str) -> float:
    """Where ``Omega/2`` meets the upper natural frequency of the pressed bearing [rad/s] (linear interpolation)."""
    upper = freqs[(name, "pressed")][0] * 2 * np.pi
    gap = np.asarray(grid) / 2 - upper
    i = int(np.flatnonzero(np.diff(np.sign(gap)))[0])
    return float(grid[i] - gap[i] * (grid[i + 1] - grid[i]) / (gap[i + 1] - gap[i]))


def rig_fe_w0() -> float:
    """The rig model's time unit: its lowest natural frequency with the bearing held [rad/s]."""
    return fe_rotor_model(load_matrices(RIG_FILE), **rig_items()).fe.units.frequency


if __name__ == "__main__":
    main()
