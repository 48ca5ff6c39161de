"""``contin plot OUTDIR --point ROW``: time history, orbit and spectrum of a stored point (:func:`draw_point`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import yaml

from contin.analyses.frequency_response import build_problem
from contin.analyses.shooting_rows import shooting_row, stored_shooting_problem
from contin.analyses.simulate import SPECTRUM_FLOOR, draw_spectrum
from contin.app.point_drawing import (closed_period, contact_geometry, contact_panels, draw_contact,
                                      draw_contact_panel, fill_places, legend_above, name_lines)
from contin.hb import aft
from contin.hb.harmonics import coefficient_blocks, default_samples, harmonic_amplitudes
from contin.output.checkpoint import CheckpointError, read_records
from contin.output.expansion import StoredExpansion, stores_kept
from contin.output.figures import figure_style, new_figure, save_figure
from contin.output.labels import axis_label, math
from contin.scene.budget import Limits, check_demands, harmonic_balance_demands
from contin.scene.build import build_model
from contin.scene.files import SUMMARY_CAP, read_input
from contin.scene.parse import SceneError, parse_scene

__all__ = ["load_state_row", "plot_point", "draw_point", "read_run_scene", "stored_expansion"]


def load_state_row(outdir: Path, row: int) -> dict:
    """The stored solution of ``branches.csv`` row ``row`` (0-based, header excluded).

    Its record of ``state.jsonl``, with ``u`` and ``tangent`` read back from ``state.bin``
    (:func:`contin.output.checkpoint.read_records`).
    """
    path = Path(outdir) / "state.jsonl"
    if not path.is_file():
        raise SceneError(str(outdir), "a result directory written by `contin run` (with state.jsonl)", None)
    try:
        records = read_records(path)
    except (CheckpointError, OSError) as exc:
        raise SceneError(str(path), "a state.jsonl written by `contin run`", None, hint=f" ({exc})") from None
    headers = {}
    for rec in records:
        if rec["type"] == "branch":
            headers[rec["branch"]] = rec
        elif rec["type"] == "point" and rec["row"] == row:
            return dict(rec, branch_record=headers.get(rec["branch"], {}))
    raise SceneError("--point", f"a row number of {path.parent / 'branches.csv'} stored in state.jsonl", row)


def _check_row_size(path: Path, row: int, rec: dict, model, H: int) -> None:
    """The stored row's coefficients match its ``H`` and the model, and its problem fits in memory: checked
    before the problem (and its arrays, which grow with ``H``) is made."""
    n = model.n_dof
    header = rec.get("branch_record") or {}
    kept = header.get("dofs") if stores_kept(header) else None
    if kept is not None and not (isinstance(kept, list) and all(isinstance(d, int) and 0 <= d < n for d in kept)):
        raise SceneError(str(path), f"row {row}'s branch record with kept dofs among the model's {n}", kept)
    n_stored = n if kept is None else len(kept)
    size = n_stored * (2 * H + 1)
    u = rec.get("u")  # a list when short, else the array read from state.bin
    if not isinstance(u, (list, np.ndarray)) or len(u) != size:
        found = f"{len(u)} values" if isinstance(u, (list, np.ndarray)) else type(u).__name__
        dofs = "1 dof" if n_stored == 1 else f"{n_stored} dofs"
        raise SceneError(str(path), f"row {row} with {size} coefficients ({dofs} x (2H+1), H = {H})", found)
    N = max(default_samples(H, model.degree), model.min_samples)
    check_demands([harmonic_balance_demands(n, H, N, f"{path} row {row} (H = {H})")], Limits.of_machine())


def read_run_scene(outdir: Path):
    """The summary of the run in ``outdir`` (``summary.json``) and the scene it holds (parsed again)."""
    outdir = Path(outdir)
    if not (outdir / "summary.json").is_file():
        raise SceneError(str(outdir), "a result directory written by `contin run` (with summary.json)", None)
    try:
        raw, _ = read_input(outdir / "summary.json", SUMMARY_CAP)  # a regular file, not a pipe or a device
        summary = json.loads(raw.decode("utf-8"))
    except OSError as exc:
        raise SceneError(str(outdir / "summary.json"), "a summary written by `contin run`", None,
                         hint=f" ({exc.strerror})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SceneError(str(outdir / "summary.json"), "a summary written by `contin run`", None,
                         hint=f" ({exc})") from None
    if not (isinstance(summary, dict) and isinstance(summary.get("scene"), dict)):
        raise SceneError(str(outdir / "summary.json"), "a summary written by `contin run` (with its scene)", None)
    return summary, parse_scene(yaml.safe_dump(summary["scene"]), str(outdir / "summary.json"))


def stored_expansion(outdir: Path) -> StoredExpansion:
    """What expands the stored unknowns of the run in ``outdir`` (its problem built only when a row needs it)."""
    def make():
        _, scene = read_run_scene(outdir)
        return build_problem(scene, build_model(scene))

    return StoredExpansion(make=make)


def _shooting_coefficients(scene, model, header: dict, rec: dict) -> np.ndarray:
    """A shooting row's coefficients from its stored state (:func:`contin.analyses.shooting_rows.shooting_row`)."""
    problem = stored_shooting_problem(build_problem(scene, model), {**header, "nu": scene.analysis["subharmonic"]})
    u = np.asarray(rec["u"], dtype=float)
    if u.shape != (problem.size,):
        raise SceneError("state.jsonl", f"a shooting row of {problem.size} values (the segment starts)",
                         f"{u.size} values")
    return shooting_row(problem, u, float(rec["lam"]), int(scene.analysis["harmonics"]), model.dof_names)[0]


def plot_point(outdir: Path, row: int, samples: int = 512) -> Path:
    """Draw the time history, orbit and spectrum of one stored solution.

    Returns
    -------
    Path
        ``OUTDIR/point_ROW.<format>``, the first of the run's ``output.formats`` (its ``style`` and
        ``dpi`` too).
    """
    outdir = Path(outdir)
    _, scene = read_run_scene(outdir)
    rec = load_state_row(outdir, row)
    header = rec["branch_record"]
    if header.get("torus") is not None:
        raise SceneError("--point", f"a row of a periodic branch (row {row} is a point of the quasi-periodic "
                                    f"branch {rec['branch']}, a torus)", row)
    nu = rec.get("nu") if isinstance(rec.get("nu"), int) and rec["nu"] >= 1 else scene.analysis.get("subharmonic", 1)
    scene.analysis["subharmonic"] = nu  # the row's own order and harmonic count
    shooting = header.get("method") == "shooting"
    H = header.get("H") if shooting else rec.get("H")  # a shooting row: nu H harmonics of w / nu
    if isinstance(H, int) and H >= 1:
        scene.analysis["harmonics"] = H
    scene.analysis["samples"] = None
    model = build_model(scene)
    if shooting:  # its state at t = 0 integrated again: the coefficients its row was written from
        rec = dict(rec, u=_shooting_coefficients(scene, model, header, rec))
    _check_row_size(outdir / "state.jsonl", row, rec, model, scene.analysis.get("harmonics", 5))
    hb = build_problem(scene, model)
    u = np.asarray(rec["u"], dtype=float) if shooting else StoredExpansion(hb)(header, rec["u"], rec["lam"])
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
    out = scene.output
    sym = getattr(model, "symbols", None)
    contacts = contact_geometry(model, p)
    panels = 3 + len(contact_panels(contacts, n))  # a contact whose dofs the orbit does not show: its own
    with figure_style(out["style"]):
        fig = new_figure((4.2 * panels, 4.2))
        axs = fig.subplots(1, panels)
        draw_point(axs, t, x, xd, amps, nu, model.dof_names, units=out["units"], labels=out["labels"], symbols=sym,
                   w=math(hb.frequency, sym).strip("$"), contacts=contacts)
        fig.suptitle(f"row {row}: branch {rec['branch']}, $\\nu$ = {nu}, {math(hb.parameter, sym)} = {lam:.6g}")
        names = save_figure(fig, outdir / f"point_{row}", out["formats"], out["dpi"])
    return outdir / names[0]


def draw_point(axs, t, x, xd, amps, nu: int, dofs, *, units=None, labels=None, symbols=None, w: str = "w",
               contacts=()) -> None:
    """Draw one periodic solution: time history, orbit (or phase portrait), each contact, harmonic spectrum.

    The time history and the orbits are closed (the first sample drawn again at ``t = T``). A contact
    (:func:`contin.app.point_drawing.contact_geometry`) is drawn with its clearance, a circle of radius
    ``clearance`` for a ``radial_gap`` and the stop lines for a ``gap``, the part of the orbit in contact
    marked: in the orbit panel when that shows its dofs, else in an axes of its own. The spectrum's main
    lines are named where no name covers another, a stem or the legend.

    Parameters
    ----------
    axs : sequence of matplotlib Axes
        ``3 + len(contact_panels(contacts, len(dofs)))``: time history, orbit, one per contact not in the
        orbit, spectrum.
    t : ndarray, shape (S,)
        One period, uniformly sampled, without its end ``t = T``.
    x, xd : ndarray, shape (S, n)
        Displacements and velocities.
    amps : ndarray, shape (H + 1, n)
        Amplitude of harmonic ``k`` of ``w/nu`` per dof (``k = 0``: the mean).
    nu : int
    dofs : sequence of str
    w : str
        Mathtext of the forcing frequency's symbol.
    contacts : sequence of dict, optional
        The model's contact elements with their clearances.
    """
    n = len(dofs)
    own = contact_panels(contacts, n)
    if len(axs) != 3 + len(own):
        raise ValueError(f"draw_point: axs must hold {3 + len(own)} axes (3 and one per contact not shown in "
                         f"the orbit), found {len(axs)}")
    t, x, xd = closed_period(t, x, xd)
    for i, d in enumerate(dofs):
        axs[0].plot(t, x[:, i], label=math(d, symbols))
    axs[0].set_xlabel("time $t$ (one period)")
    axs[0].set_ylabel("displacement")
    legend_above(axs[0], ncols=min(n, 4))
    if n >= 2:
        axs[1].plot(x[:, 0], x[:, 1])
        axs[1].set_xlabel(axis_label(dofs[0], units, labels, symbols))
        axs[1].set_ylabel(axis_label(dofs[1], units, labels, symbols))
        axs[1].set_title("orbit")
    else:
        axs[1].plot(x[:, 0], xd[:, 0])
        axs[1].set_xlabel(axis_label(dofs[0], units, labels, symbols))
        axs[1].set_ylabel(axis_label(dofs[0] + "_dot", units, labels, symbols))
        axs[1].set_title("phase portrait")
    inside = [c for c in contacts if not any(c is o for o in own)]
    for k, c in enumerate(inside):  # the orbit panel shows these contacts' dofs
        X, Y = axs[1].get_lines()[0].get_xdata(), axs[1].get_lines()[0].get_ydata()
        draw_contact(axs[1], c, X, Y, x, horizontal=c["type"] == "radial_gap" or c["dof"] == 0, label=k == 0)
        if c["type"] == "radial_gap":
            axs[1].set_aspect("equal", adjustable="box")
    if inside:
        legend_above(axs[1])
    for ax, c in zip(axs[2:-1], own):
        draw_contact_panel(ax, c, x, xd, dofs, units=units, labels=labels, symbols=symbols)
    spec = axs[-1]
    freqs = np.arange(amps.shape[0]) / nu
    width = 0.6 / (n * nu)
    top = float(np.max(amps)) if amps.size else 0.0
    for i, d in enumerate(dofs):  # harmonic amplitudes as stems, cut at the spectrum floor, main ones named
        draw_spectrum(spec, freqs + (i - (n - 1) / 2) * width, amps[:, i], w=w, fmax=np.inf, stems=True,
                      label=math(d, symbols), color=f"C{i}", annotate=False)
    spec.set_xlabel(f"frequency / ${w}$")
    spec.set_ylabel("harmonic amplitude")
    spec.set_title("spectrum")
    if n > 1:
        spec.legend(loc="upper right")
    fill_places(axs[1:-1])
    if top > 0:
        spec.set_ylim(top * SPECTRUM_FLOOR, top * 10.0)  # a decade above the largest line for the names
        main = [(float(freqs[k]), float(amps[k].max())) for k in np.argsort(amps.max(axis=1))[::-1][:5]
                if amps[k].max() >= 1e3 * SPECTRUM_FLOOR * top]
        name_lines(spec, main, w)
