"""``bifurcation_curve``: period doublings of the integrated flow, the reference its curves are checked against.

:func:`shooting_reference` finds, by shooting on the integrated equations of
motion (:mod:`contin.timedomain.shooting`), the period doublings at the
``analysis.shooting`` values of the second parameter, and writes them to
``shooting_points.csv`` with the nearest harmonic-balance curve and its
distance; :func:`shooting_options` reads ``analysis.shooting_options``. The
analysis itself is :mod:`contin.analyses.bifurcation_curve`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.bifurcation.start import integrated_model
from contin.scene.schema import SceneError
from contin.stability import orbit_state
from contin.timedomain.shooting import ShootingOptions, period_doubling_scan, periodic_orbit

__all__ = ["shooting_options", "shooting_reference"]


def shooting_options(scene) -> ShootingOptions:
    """``analysis.shooting_options``, with the orbit's period ``subharmonic`` forcing periods by default."""
    d = {"subharmonic": scene.analysis["subharmonic"], **dict(scene.analysis["shooting_options"])}
    internal = [f.name for f in dataclasses.fields(ShootingOptions) if f.metadata.get("scene") is False]
    for k in d:
        if k in internal:
            raise SceneError(f"analysis.shooting_options.{k}", "a key a scene sets (its orbits are shot from "
                             "forcing phase zero)", d[k])
    try:
        return ShootingOptions.from_dict(d)
    except (ValueError, TypeError) as exc:
        raise SceneError("analysis.shooting_options", "valid ShootingOptions fields", None,
                         hint=f": {exc}") from None


def _mutual_nearest(x: float, xs, crossing):
    """``(curve, p1)`` of the curve crossing nearest to ``x`` if ``x`` is also the point of ``xs`` nearest to it."""
    if not crossing:
        return None
    cid, q = min(crossing, key=lambda c: abs(c[1] - x))
    return (cid, q) if min(xs, key=lambda y: abs(y - q)) == x else None


def _orbit_towards(model, p1, p2, lam0, a, b, z, opt, max_halvings=6):
    """The shooting orbit at ``p2 = b`` (``p1 = lam0``) from the one at ``p2 = a``, in smaller steps where needed."""
    orb = None
    for k in range(max_halvings + 1):
        steps = 2 ** k
        zz, ok = z, True
        for v in np.linspace(a, b, steps + 1)[1:]:
            orb = periodic_orbit(model, {p1: lam0, p2: float(v)}, zz, opt)
            if not orb.converged:
                ok = False
                break
            zz = orb.state
        if ok:
            return orb
    return orb


def shooting_reference(ctx, opt: ShootingOptions, problem0, branch0, curves, p1, p2, p2_value, range1) -> dict:
    """Period doublings of the integrated flow (:mod:`contin.timedomain.shooting`) at ``analysis.shooting`` values of ``p2``.

    The orbit at the start of the first one-parameter run is followed in ``p2``
    (outwards from the scene's value) and, at each value, over a grid of
    ``shooting_points`` values of ``p1`` from that start to each end of
    ``range``. Each period doubling is written to ``shooting_points.csv`` with
    the nearest harmonic-balance curve and its distance. With
    ``shooting_refine > 0``, where the period doublings vanish between two
    values, the end of the region is bracketed by that many bisections in ``p2``.
    ``opt``: the shooting's options (:func:`shooting_options`).
    """
    a = ctx.scene.analysis
    model = integrated_model(problem0)  # integrated at the problem's frequency
    lam0 = float(branch0.parameter[0])
    z0 = orbit_state(problem0, branch0.unknowns[0], lam0, 0.0)
    lo, hi = range1
    k = a["shooting_points"]
    grids = [g for g in (np.linspace(lam0, hi, k), np.linspace(lam0, lo, k)) if abs(g[-1] - g[0]) > 0]
    rows, runs, brackets = [], [], []

    def scan_at(value, z):
        found = []
        for grid in grids:
            sc = period_doubling_scan(model, {p2: value}, p1, grid, z, opt)
            found += [(float(o.params[p1]), ok, o) for o, ok in zip(sc.points, sc.located)]
            if sc.status != "complete":
                return found, sc.message
        return sorted(found, key=lambda t: t[0]), ""

    def add_rows(value, found):
        crossing = [(cid, q1) for cid, cur in enumerate(curves) if cur.kind.value == "pd"
                    for q1, _ in cur.crossings(value)]
        for w, ok, o in found:
            near = _mutual_nearest(w, [x for x, _, _ in found], crossing)
            rows.append({p2: value, p1: w, "located": ok, "max_multiplier": float(np.abs(o.multipliers).max()),
                         "curve": None if near is None else near[0], f"curve_{p1}": None if near is None else near[1],
                         "distance": None if near is None else abs(near[1] - w)})

    values = sorted({float(v) for v in a["shooting"]})
    found_at = {}
    for side in ([v for v in values if v >= p2_value], [v for v in reversed(values) if v < p2_value]):
        z, cur = z0, p2_value
        for value in side:
            if ctx.stop_requested:
                break
            ctx.progress.update(f"shooting at {p2}={value:.6g}", task="shooting")
            orb = _orbit_towards(model, p1, p2, lam0, cur, value, z, opt)
            if orb is None or not orb.converged:
                runs.append({p2: value, "status": "failed", "message": f"the orbit at {p1} = {lam0:g} was lost "
                             f"on the way from {p2} = {cur:g}: {orb.message if orb else ''}"})
                break
            z, cur = orb.state, value
            found, why = scan_at(value, z)
            found_at[value] = (found, z)
            add_rows(value, found)
            runs.append({p2: value, "status": "failed" if why else "complete", "message": why,
                         "period_doublings": [w for w, ok, _ in found if ok]})
    keys = sorted(found_at)
    for u, v in zip(keys, keys[1:]):
        if bool(found_at[u][0]) == bool(found_at[v][0]) or not a["shooting_refine"]:
            continue
        inside, outside = (u, v) if found_at[u][0] else (v, u)
        z = found_at[inside][1]
        for _ in range(a["shooting_refine"]):
            mid = round(0.5 * (inside + outside), 12)
            orb = _orbit_towards(model, p1, p2, lam0, inside, mid, z, opt)
            if not orb.converged:
                break
            found, _ = scan_at(mid, orb.state)
            add_rows(mid, found)  # the region narrowing towards its end
            if found:
                inside, z = mid, orb.state
            else:
                outside = mid
        brackets.append({"inside": inside, "outside": outside})
    out = ctx.sink.table("shooting_points.csv", [p2, p1, "located", "max_multiplier", "curve", f"curve_{p1}",
                                                  "distance"])
    try:
        for r in rows:
            out.write(r)
    finally:
        out.close()
    dist = [r["distance"] for r in rows if r["distance"] is not None]
    return {"options": dataclasses.asdict(opt), "runs": runs, "region_ends": brackets,
            "max_distance_to_curves": max(dist, default=None),
            "points": [{"kind": "pd", "x": r[p1], "y": r[p2]} for r in rows if r["located"]]}
