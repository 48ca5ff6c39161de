"""``contin plot OUTDIR --point ROW``: time history, orbit and spectrum of a stored point."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml

from contin.hb import aft
from contin.hb.harmonics import coefficient_blocks, harmonic_amplitudes
from contin.output.checkpoint import CheckpointError, read_records
from contin.scene.parse import SceneError, parse_scene

__all__ = ["load_state_row", "plot_point"]


def load_state_row(outdir: Path, row: int) -> dict:
    """The stored solution of ``branches.csv`` row ``row`` (0-based, header excluded)."""
    path = Path(outdir) / "state.jsonl"
    if not path.is_file():
        raise SceneError(str(outdir), "a result directory written by `contin run` (with state.jsonl)", None)
    try:
        records = read_records(path)
    except (CheckpointError, OSError) as exc:
        raise SceneError(str(path), "a state.jsonl written by `contin run`", None, hint=f" ({exc})") from None
    for rec in records:
        if rec["type"] == "point" and rec["row"] == row:
            return rec
    raise SceneError("--point", f"a row number of {path.parent / 'branches.csv'} stored in state.jsonl", row)


def plot_point(outdir: Path, row: int, samples: int = 512) -> Path:
    """Draw the time history, orbit and spectrum of one stored solution.

    Returns
    -------
    Path
        ``OUTDIR/point_ROW.png``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from contin.analyses.frequency_response import build_problem
    from contin.scene.build import build_model

    outdir = Path(outdir)
    if not (outdir / "summary.json").is_file():
        raise SceneError(str(outdir), "a result directory written by `contin run` (with summary.json)", None)
    try:
        summary = json.loads((outdir / "summary.json").read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SceneError(str(outdir / "summary.json"), "a summary written by `contin run`", None,
                         hint=f" ({exc})") from None
    if not (isinstance(summary, dict) and isinstance(summary.get("scene"), dict)):
        raise SceneError(str(outdir / "summary.json"), "a summary written by `contin run` (with its scene)", None)
    scene = parse_scene(yaml.safe_dump(summary["scene"]), str(outdir / "summary.json"))
    rec = load_state_row(outdir, row)
    nu = rec.get("nu") if isinstance(rec.get("nu"), int) and rec["nu"] >= 1 else scene.analysis.get("subharmonic", 1)
    scene.analysis["subharmonic"] = nu  # the row's own order and harmonic count
    if isinstance(rec.get("H"), int) and rec["H"] >= 1:
        scene.analysis["harmonics"] = rec["H"]
    scene.analysis["samples"] = None
    model = build_model(scene)
    hb = build_problem(scene, model)
    u = np.asarray(rec["u"], float)
    if u.shape != (hb.size,) or not np.all(np.isfinite(u)):
        raise SceneError(str(outdir / "state.jsonl"), f"row {row} with {hb.size} finite coefficients",
                         f"{u.size} values")
    lam = rec["lam"]
    n = model.n_dof
    p = hb.params_at(lam)
    Omega = hb.base_frequency(p)
    T = hb.period(p) if Omega != 0 else 2 * np.pi * nu  # at rest in time: one period of the phase
    x, xp = aft.synthesize(np.ascontiguousarray(coefficient_blocks(u, n)), samples)
    t = np.linspace(0, T, samples, endpoint=False)
    xd = Omega * xp
    amps = harmonic_amplitudes(u, n)
    fig, axs = plt.subplots(1, 3, figsize=(12, 3.8), constrained_layout=True)
    for i, d in enumerate(model.dof_names):
        axs[0].plot(t, x[:, i], label=d)
    axs[0].set_xlabel("t (one period)")
    axs[0].set_ylabel("displacement")
    axs[0].legend(fontsize=8)
    if n >= 2:
        axs[1].plot(x[:, 0], x[:, 1])
        axs[1].set_xlabel(model.dof_names[0])
        axs[1].set_ylabel(model.dof_names[1])
        axs[1].set_title("orbit")
    else:
        axs[1].plot(x[:, 0], xd[:, 0])
        axs[1].set_xlabel(model.dof_names[0])
        axs[1].set_ylabel(model.dof_names[0] + "_dot")
        axs[1].set_title("phase portrait")
    freqs = np.arange(amps.shape[0]) / nu
    width = 0.8 / (n * nu)
    for i, d in enumerate(model.dof_names):
        axs[2].bar(freqs + (i - (n - 1) / 2) * width, amps[:, i], width=width, label=d)
    axs[2].set_xlabel("frequency / w")
    axs[2].set_ylabel("harmonic amplitude")
    axs[2].set_yscale("log")
    axs[2].set_title("spectrum")
    fig.suptitle(f"row {row}: branch {rec['branch']}, nu={nu}, {hb.parameter}={lam:.6g}")
    path = outdir / f"point_{row}.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
