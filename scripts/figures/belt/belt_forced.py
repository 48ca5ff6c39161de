"""Figure 9 of the timing-belt paper: forced response with and without the magnet, and the switching path.

alpha = 0.005, beta = 0.2, xi1 = 0.4, p_s = 0, p_d = 2, gamma0..3 = 50, 5, 0.313,
0.0156, read as w_rms at xi = 0.6. The paper has no damping; here a tiny modal
damping zeta = 0.005 keeps the superharmonic resonances (w1/3, w1/5, ...)
finite so that a branch can pass them (undamped, each of them is an infinitely
tall spike that traps the continuation). The runs are those of the scenes
``scenes/belt_forced_on.yaml`` and ``scenes/belt_forced_off.yaml``:

- magnet on: one branch from w = 0.5 to 8, the softening-hardening first-mode
  resonance with its folds (H = 9: with fewer harmonics an internal resonance
  that ends the peak at w = 3.94 is missed, see scripts/bench/bench_belt.py);
- magnet off: the hardening first-mode resonance, in pieces (with this damping
  its peak lies near w = 11 and its upper branch meets internal resonances
  above w = 3.7): up from w = 0.5 to 3.6 on the resonant branch; down from 3.6
  on the small response to its fold (the jump up) and back on the unstable
  middle branch; down from 8 to 3.6 across the weak second-mode resonance.

The magnet switching path (the paper's thick line): the magnet is on at low
frequency, where the magnet-off belt would resonate near w = 2.7, and is
switched off before the magnet-on resonance (near w = 4.8); the script switches
where the two small responses are equally large, between the magnet-off fold
and the magnet-on fold, and prints the largest w_rms along the path against the
resonance peaks it avoids. Without ``--quick`` it also integrates the switch in
time (RK4) from the magnet-on small response at the switching frequency and
reports where the motion settles, for a magnet switched off at once and for
one ramped off over 200 forcing periods. Switching at once releases the
static deflection (w = 11 at xi = 0.6) as a large free vibration, and
whether the belt then settles on the small response or on the coexisting
magnet-off resonance depends on the frequency (basins of attraction); the
slow ramp follows the paper's path. Writes ``belt_fig9_forced.png`` and prints
the folds.

    python scripts/figures/belt/belt_forced.py [--quick] [--out DIR]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from contin.util.blas import limit_blas_threads
from contin.output.results import read_csv
from contin.app.runner import run_scene
from contin.scene.parse import load_scene

ROOT = Path(__file__).resolve().parents[3]


def run(scene_name, outdir, sets=()):
    scene = load_scene(ROOT / "scenes" / scene_name, list(sets) + ["output.plots=false"])
    t0 = time.perf_counter()
    summary = run_scene(scene, outdir, progress=False)
    rows = read_csv(outdir / "branches.csv")
    sp = read_csv(outdir / "special_points.csv")
    print(f"    {scene_name} {' '.join(sets)}: {len(rows['w'])} points in {time.perf_counter() - t0:.1f} s")
    for b in summary["analysis"]["branches"]:
        if b["status"] != "range_end":
            print(f"    note: {scene_name} {list(sets)}: branch {b['branch']} {b['status']}: {b['message']}")
    return rows, sp


def lower_branch(rows, lo, hi):
    """Stable rows of the small response with lo <= w <= hi, sorted in w (w_rms below 2)."""
    sel = rows["stable"].astype(bool) & (rows["w"] >= lo) & (rows["w"] <= hi) & (rows["w_rms"] < 2.0)
    order = np.argsort(rows["w"][sel])
    return rows["w"][sel][order], rows["w_rms"][sel][order]


def switching_frequency(on, off, lo, hi):
    """Where the two small responses are equally large in [lo, hi] (or the end where off is smaller)."""
    grid = np.linspace(lo, hi, 2001)
    d = np.interp(grid, *on) - np.interp(grid, *off)
    cross = np.flatnonzero(np.diff(np.sign(d)) != 0)
    if cross.size:
        i = cross[0]
        return grid[i] - d[i] * (grid[i + 1] - grid[i]) / (d[i + 1] - d[i])
    return lo if d[0] > 0 else hi


def simulate_switch(w_s, zeta, ramp_periods=200):
    """Time integration of the switch at ``w_s``, from the magnet-on small response.

    Returns w_rms (about the mean, at xi = 0.6) on the magnet-on response,
    after an abrupt switch-off, and after a switch-off ramped linearly over
    ``ramp_periods`` forcing periods (piecewise constant per period); each
    followed by 1500 periods without the magnet.
    """
    from contin.model.catalog import build_model
    from contin.hb.problem import HarmonicBalance, HBOptions
    from contin.models.timing_belt import PAPER_MAGNET, shape_values
    from contin.engine.newton import solve_at_parameter
    from contin.timedomain.simulation import simulate

    c = shape_values(5, 0.6)
    S = 128
    effects = ["rotor_mass", "stretching", "magnet", "periodic_load", "damping"]

    def belt(scale):
        return build_model("timing_belt", {"p_d": 2.0, "zeta": zeta,
                                           **{f"gamma{k}": scale * g for k, g in enumerate(PAPER_MAGNET)}},
                           effects if scale > 0 else [e for e in effects if e != "magnet"])

    def rms(run):
        y = run.x[:-1] @ c
        return float(np.sqrt(np.mean((y - y.mean()) ** 2)))

    on = belt(1.0)
    hb = HarmonicBalance(on, "w", HBOptions(harmonics=5))
    res = solve_at_parameter(hb, on.start(hb, w_s), w_s)  # the magnet-on small response (the path)
    U = res.x.reshape(-1, 5)
    k = np.arange(1, 6)
    x0, v0 = U[0] + U[1::2].sum(axis=0), w_s * (k[:, None] * U[2::2]).sum(axis=0)
    r = simulate(on, {"w": w_s}, x0, v0, periods=200, steps_per_period=S, record_every=1, record_from=180)
    before = rms(r)
    out = []
    for ramp in (0, ramp_periods):
        x, v = r.final_state[:5], r.final_state[5:]
        for j in range(ramp):  # whole forcing periods: the phase carries over
            step = simulate(belt(1.0 - (j + 1) / ramp), {"w": w_s}, x, v, periods=1, steps_per_period=S,
                            record_every=S)
            x, v = step.final_state[:5], step.final_state[5:]
        after = simulate(belt(0.0), {"w": w_s}, x, v, periods=1500, steps_per_period=S, record_every=1,
                         record_from=1480)
        out.append(rms(after))
    return before, out[0], out[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="narrow ranges, H = 3, longer steps, no time integration")
    ap.add_argument("--out", default="results/belt")
    args = ap.parse_args(argv)
    limit_blas_threads(1)  # small matrices: one BLAS thread is faster (see README)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    q = args.quick
    # the scenes use H = 9 and steps of 0.01 .. 0.05 of the range; quick: H = 3 and longer steps
    H = ["analysis.harmonics=3", "analysis.continuation={ds: 0.04, ds_max: 0.2, max_points: 3000}"] if q else []
    print("Fig. 9: forced response, p_d = 2, zeta = 0.005 (w_rms at xi = 0.6)")
    on_rows, on_sp = run("belt_forced_on.yaml", out / "forced_on",
                         H + (["analysis.range=[3.0, 6.0]"] if q else []))
    pieces = [("up from low w", ["analysis.start=0.5"] + (["analysis.range=[2.0, 3.6]", "analysis.start=2.0"]
                                                          if q else [])),
              ("down from 3.6", (["analysis.range=[2.8, 3.6]"] if q else [])),
              ("down from 8", ["analysis.range=[3.6, 8.0]", "analysis.start=8.0"] + (
                  ["analysis.range=[3.6, 4.6]", "analysis.start=4.6"] if q else []))]
    off = []
    for j, (label, sets) in enumerate(pieces):
        off.append((label,) + run("belt_forced_off.yaml", out / f"forced_off_{j}", H + sets))
    print("  folds (jumps), magnet on : " + ", ".join(
        f"w = {w:.5f} (w_rms {a:.4f})" for w, a, k in zip(on_sp["w"], on_sp["w_rms"], on_sp["kind"]) if k == "fold"))
    folds_off = [(w, a) for _, _, sp in off for w, a, k in zip(sp["w"], sp["w_rms"], sp["kind"]) if k == "fold"]
    print("  folds (jumps), magnet off: " + ", ".join(f"w = {w:.5f} (w_rms {a:.4f})" for w, a in folds_off))
    for label, sp_rows in (("on", on_sp),) + tuple((f"off {lab}", sp) for lab, _, sp in off):
        other = [(k, w) for k, w in zip(sp_rows["kind"], sp_rows["w"]) if k in ("ns", "pd", "bp")]
        if other:
            print(f"  other bifurcations, magnet {label}: " + ", ".join(f"{k} at w = {w:.4f}" for k, w in other))

    # the switching path
    on_folds = sorted(w for w, k in zip(on_sp["w"], on_sp["kind"]) if k == "fold")
    off_fold = min((w for w, _ in folds_off), default=None)
    path = None
    if on_folds and off_fold is not None:
        w_jump_on = max(w for w, a, k in zip(on_sp["w"], on_sp["w_rms"], on_sp["kind"]) if k == "fold" and a < 2.0)
        on_low = lower_branch(on_rows, 0.0, w_jump_on)
        off_rows = {k: np.concatenate([rows[k] for _, rows, _ in off[1:]]) for k in ("w", "w_rms", "stable")}
        off_low = lower_branch(off_rows, off_fold, np.inf)
        lo, hi = max(off_fold, off_low[0][0], on_low[0][0]), min(w_jump_on, off_low[0][-1], on_low[0][-1])
        if lo < hi:
            w_s = switching_frequency(on_low, off_low, lo, hi)
            path = (w_s, on_low, off_low)
            peak_path = max(np.interp(w_s, *on_low), on_low[1][on_low[0] <= w_s].max(),
                            off_low[1][off_low[0] >= w_s].max())
            print(f"  switching path: magnet on for w < {w_s:.4f}, off above (between the magnet-off fold "
                  f"{off_fold:.4f} and the magnet-on jump {w_jump_on:.4f}); largest w_rms on the path "
                  f"{peak_path:.4f}, against {on_rows['w_rms'].max():.3f} (magnet-on resonance) and "
                  f"{max(r['w_rms'].max() for _, r, _ in off):.3f} (magnet-off resonance, within the range)")
            if not q:
                t0 = time.perf_counter()
                before, abrupt, ramped = simulate_switch(w_s, 0.005)
                print(f"    time integration of the switch: {time.perf_counter() - t0:.1f} s")
                small = float(np.interp(w_s, *off_low))

                def verdict(a):
                    return "the small response" if abs(a - small) < 0.1 * small + 0.02 else "the resonance"

                print(f"  time integration at w = {w_s:.4f} from the magnet-on small response (w_rms {before:.4f}): "
                      f"switched off at once -> w_rms {abrupt:.4f} ({verdict(abrupt)}); ramped off over 200 "
                      f"periods -> {ramped:.4f} ({verdict(ramped)}); the magnet-off small response has {small:.4f}")
    _plot(out / "belt_fig9_forced.png", on_rows, on_sp, off, path)
    print(f"  wrote {out / 'belt_fig9_forced.png'}")


def _segments(ax, rows, color, label):
    first = True
    for b in np.unique(rows["branch"]):
        sel = rows["branch"] == b
        w, a, st = rows["w"][sel], rows["w_rms"][sel], rows["stable"][sel].astype(bool)
        for stable in (True, False):
            keep = (st == stable) | np.r_[st[1:] == stable, False] | np.r_[False, st[:-1] == stable]
            if keep.any():
                ax.plot(np.where(keep, w, np.nan), np.where(keep, a, np.nan), "-" if stable else "--", color=color,
                        lw=1.0, label=label if first and stable else None)
                first = first and not stable


def _plot(path, on_rows, on_sp, off, switch):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.2, 4.8), constrained_layout=True)
    _segments(ax, on_rows, "tab:red", "magnet on")
    for j, (_, rows, _) in enumerate(off):
        _segments(ax, rows, "tab:blue", "magnet off" if j == 0 else None)
    for rows_sp, color in [(sp, "tab:blue") for _, _, sp in off] + [(on_sp, "tab:red")]:
        f = rows_sp["kind"] == "fold"
        ax.plot(rows_sp["w"][f], rows_sp["w_rms"][f], "o", mfc="none", color=color)
    if switch is not None:
        w_s, on_low, off_low = switch
        a = on_low[0] <= w_s
        b = off_low[0] >= w_s
        ax.plot(np.r_[on_low[0][a], w_s], np.r_[on_low[1][a], np.interp(w_s, *on_low)], "k-", lw=3.0,
                label=f"switching path (off at w = {w_s:.3f})")
        ax.plot(np.r_[w_s, off_low[0][b]], np.r_[np.interp(w_s, *off_low), off_low[1][b]], "k-", lw=3.0)
        ax.plot([w_s, w_s], [np.interp(w_s, *on_low), np.interp(w_s, *off_low)], "k-", lw=3.0)
    ax.set_yscale("log")
    ax.set_xlabel(r"excitation frequency $\Omega$")
    ax.set_ylabel(r"RMS of $w$ at $\xi = 0.6$")
    ax.set_title(r"Fig. 9: $p_d = 2$, $\zeta = 0.005$ (dashed: unstable, o: folds)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=130)
    plt.close(fig)


if __name__ == "__main__":
    main()
