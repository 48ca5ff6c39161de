"""Forward and backward whirl radii of node pairs ``(x, y)``: the rotor models' ``branches.csv`` columns."""

from __future__ import annotations

import numpy as np

__all__ = ["TORUS_WHIRL", "WHIRL_COLUMNS", "WHIRL_SYMBOLS", "whirl_radii"]

#: ``whirl_{fwd,bwd}_{half,1}_{disc,bearing}``: the radii at w/2 and at w of the disc and the bearing
WHIRL_COLUMNS = tuple(f"whirl_{d}_{f}_{part}" for part in ("disc", "bearing") for f in ("half", "1")
                      for d in ("fwd", "bwd"))

#: the whirls only a torus has, by column prefix: the self-excited forward whirl at ``+w2`` (the line
#: ``(0, 1)``) and the combination, backward at ``w2 - w`` (the line ``(1, -1)``)
TORUS_WHIRL = {"whirl_fwd_free": ((0, 1), True), "whirl_bwd_comb": ((1, -1), False)}

#: how figures write the whirl columns (:mod:`contin.output.labels`)
WHIRL_SYMBOLS = {**{f"whirl_{d}_{f}_{part}": f"{word} whirl of the {part} at ${speed}$"
                    for d, word in (("fwd", "forward"), ("bwd", "backward"))
                    for f, speed in (("half", r"\Omega/2"), ("1", r"\Omega")) for part in ("disc", "bearing")},
                 **{f"whirl_fwd_free_{part}": f"self-excited forward whirl of the {part} at $p_f$"
                    for part in ("disc", "bearing")},
                 **{f"whirl_bwd_comb_{part}": f"backward whirl of the {part} at $\\Omega - p_f$"
                    for part in ("disc", "bearing")}}


def whirl_radii(u: np.ndarray, n_dof: int, nu: int, parts: dict) -> dict:
    """Forward and backward whirl radii of each part at w/2 and at w.

    With ``x = a cos(k theta) + b sin(k theta)`` and ``y = c cos(k theta) + d sin(k theta)``,
    ``x + i y = F e^{i k theta} + B e^{-i k theta}`` with
    ``|F| = |(a + d) + i(c - b)|/2`` (forward) and ``|B| = |(a - d) + i(c + b)|/2``
    (backward). The ``w/2`` component is harmonic ``k = nu/2`` of the base
    frequency ``w/nu`` (zero for ``nu = 1``); the ``w`` component is ``k = nu``.

    Parameters
    ----------
    u : ndarray, shape (n_dof (2H+1),)
        Coefficients in the order of :mod:`contin.hb.harmonics`.
    n_dof, nu : int
    parts : dict
        Part name (``disc``, ``bearing``) -> its ``(x, y)`` dof indices.

    Returns
    -------
    dict
        ``whirl_{fwd,bwd}_{half,1}_{part}``.
    """
    U = np.asarray(u).reshape(-1, n_dof)
    H = (U.shape[0] - 1) // 2
    out = {}
    for part, (ix, iy) in parts.items():
        for label, num in (("half", 1), ("1", 2)):
            k2 = nu * num  # 2k: the component is k = nu*num/2
            fwd = bwd = 0.0
            if k2 % 2 == 0 and 1 <= k2 // 2 <= H:
                k = k2 // 2
                a, b = U[2 * k - 1, ix], U[2 * k, ix]
                c, d = U[2 * k - 1, iy], U[2 * k, iy]
                fwd = 0.5 * float(np.hypot(a + d, c - b))
                bwd = 0.5 * float(np.hypot(a - d, c + b))
            out[f"whirl_fwd_{label}_{part}"] = fwd
            out[f"whirl_bwd_{label}_{part}"] = bwd
    return out
