"""The stability monitor of the continuation engine: a verdict at every point of a branch.

:class:`StabilityMonitor` computes :func:`~contin.stability.floquet.floquet_multipliers`
at each point the engine stores or tries, remembers the previous verdict (so
that method BOTH checks each change of Hill's verdict by the monodromy),
keeps the statistics of the cross-checks, keeps a point where no verdict can
be made (with finite placeholders) instead of ending the branch, and saves
and restores what it remembers for a resumed run. Where Hill's verdict was
replaced, :meth:`StabilityMonitor.report` tells it once per branch: how many
of the branch's points, and over which ranges of the parameter
(:func:`replaced_ranges`).
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Mapping

import numpy as np

from contin.engine.newton import NUMERICAL_ERRORS
from contin.util.warning import ContinWarning
from contin.stability.floquet import floquet_multipliers
from contin.stability.options import StabilityMethod, StabilityOptions
from contin.stability.verdict import FloquetResult, unevaluated_data

__all__ = ["StabilityMonitor", "replaced_ranges", "describe_ranges"]


class StabilityMonitor:
    """Monitor for :func:`contin.engine.continuation.continuation`: stability at each point.

    Called as ``monitor(u, lam, Ju, Jlam)``, it returns (see
    :meth:`FloquetResult.monitor_data`) ``evaluated`` (True), ``stable``,
    ``n_unstable``, ``n_plus``, ``n_minus``, ``n_complex``,
    ``max_multiplier``, ``multipliers`` (2n complex), ``ambiguous``,
    ``hill_quality`` (-1 when Hill was not used), ``confirmed``,
    ``disagreement`` (Hill and monodromy verdicts differ, not explained by
    a multiplier on the threshold), ``marginal_disagreement`` and
    ``hill_fallback``. With method BOTH it remembers the verdict of the
    previously evaluated point, so that each change of Hill's verdict is
    checked by the monodromy.

    Where no verdict can be made (a numerical failure: an ``ArithmeticError``
    or ``LinAlgError``, e.g. a monodromy that would need more steps than
    ``StabilityOptions.max_steps_per_period`` allow), it does not raise,
    which would end the branch: it returns :func:`~contin.stability.verdict.unevaluated_data`
    (``evaluated`` False, finite placeholders) and records the parameter
    and the reason in :attr:`unevaluated` (the first one also raises a
    :class:`~contin.util.warning.ContinWarning`). The stability events take
    such a point as giving no information
    (:func:`~contin.stability.events.stability_events`).

    Parameters
    ----------
    hb : HarmonicBalance
    options : StabilityOptions, optional

    Attributes
    ----------
    evaluations, confirmations : int
    disagreements : list of float
        Parameter values where Hill and the monodromy disagreed beyond the
        threshold margin (the monodromy's verdict was used), at every
        evaluation (rejected steps and the location of special points
        included); :meth:`report` counts the branch's points alone.
    marginal_disagreements : list of float
        Parameter values where they disagreed with a multiplier on the
        threshold (at a bifurcation, within the methods' accuracy).
    ambiguous_points : list of float
        Parameter values where Hill's selection was ambiguous.
    fallbacks : list of float
        Parameter values where Hill's multipliers, near ``+1`` or ``-1``,
        differed from the monodromy's beyond ``StabilityOptions.agreement``
        and the monodromy's were used (told by :meth:`report`).
    largest_gap : float
        Largest Hill-monodromy multiplier distance met where both were computed.
    unevaluated : list of (float, str)
        Parameter values where no verdict could be made, with the reason.
    last : FloquetResult or None
    """

    def __init__(self, hb, options: StabilityOptions | None = None):
        self.hb = hb
        self.options = StabilityOptions() if options is None else options
        if self.options.method is StabilityMethod.NONE:
            raise ValueError("StabilityMonitor needs a stability method other than 'none'")
        self.evaluations = 0
        self.confirmations = 0
        self.disagreements: list[float] = []
        self.marginal_disagreements: list[float] = []
        self.ambiguous_points: list[float] = []
        self.fallbacks: list[float] = []
        self.unevaluated: list[tuple[float, str]] = []
        self.largest_gap = 0.0
        self.last: FloquetResult | None = None
        self._last_key = None
        self._size: int | None = None  # multipliers per point, as last returned
        self._restored_counts = None  # the last verdict's counts given back by restore()
        # what report() quotes of the first replacement of each kind since the last report
        self._first_disagreement: tuple[float, str] | None = None
        self._first_fallback: tuple[float, str] | None = None

    def analyze(self, u: np.ndarray, lam: float) -> FloquetResult:
        """:func:`floquet_multipliers` at ``(u, lam)``, updating the remembered verdict."""
        key = (np.asarray(u, dtype=float).tobytes(), float(lam))
        if key == self._last_key and self.last is not None:
            return self.last
        # a condensed problem (contin.hb.condensation): Hill and the monodromy on the full problem and coefficients
        hb = self.hb.full
        uf = self.hb.expand(u, lam) if self.hb.condensed else u
        previous = self._restored_counts if self.last is None else self.last.counts
        res = floquet_multipliers(hb, uf, lam, self.options, previous=previous)
        self.evaluations += 1
        self.confirmations += int(res.confirmed)
        if res.disagreement:
            (self.marginal_disagreements if res.marginal else self.disagreements).append(float(lam))
            if not res.marginal and self._first_disagreement is None:
                self._first_disagreement = (float(lam), f"Hill |mu|max={np.abs(res.hill_multipliers).max():.6g}, "
                                            f"monodromy |mu|max={np.abs(res.monodromy_multipliers).max():.6g} at "
                                            f"{self.hb.parameter}={lam:.10g}")
        if math.isfinite(res.gap):
            self.largest_gap = max(self.largest_gap, float(res.gap))
        if res.fallback:
            self.fallbacks.append(float(lam))
            if self._first_fallback is None:
                self._first_fallback = (float(lam), f"by {res.gap:.2g} at {self.hb.parameter}={lam:.10g}")
        if res.ambiguous:
            self.ambiguous_points.append(float(lam))
        self.last = res
        self._last_key = key
        return res

    def __call__(self, u, lam, Ju=None, Jlam=None) -> dict:
        try:
            data = self.analyze(u, lam).monitor_data()
        except NUMERICAL_ERRORS as exc:
            return self._unevaluated(float(lam), f"{type(exc).__name__}: {exc}")
        self._size = int(np.size(data["multipliers"]))
        return data

    def _unevaluated(self, lam: float, reason: str) -> dict:
        """Record a point without a verdict; its placeholder data."""
        self.unevaluated.append((lam, reason))
        if len(self.unevaluated) == 1:
            warnings.warn(
                f"no stability verdict at {getattr(self.hb, 'parameter', 'lambda')}={lam:.10g} ({reason}); the point "
                "is kept without one "
                "(evaluated False; further ones are listed in StabilityMonitor.unevaluated without warning)",
                ContinWarning,
                stacklevel=3,
            )
        return unevaluated_data(self._multiplier_count(lam))

    def _multiplier_count(self, lam: float) -> int:
        """How many multipliers the points have: those of the last verdict, else ``2 rank(M)`` (Hill's count)."""
        if self._size is not None:
            return self._size
        if self.hb is None:
            return 0
        hb = self.hb.full
        return 2 * int(np.linalg.matrix_rank(hb.model.linear(hb.params_at(lam))[0]))

    def state(self) -> dict:
        """What the monitor remembers, JSON-able: its statistics and the last verdict's counts (see :meth:`restore`)."""
        return {"evaluations": self.evaluations, "confirmations": self.confirmations,
                "disagreements": list(self.disagreements), "marginal_disagreements": list(self.marginal_disagreements),
                "ambiguous_points": list(self.ambiguous_points), "fallbacks": list(self.fallbacks),
                "unevaluated": [[lam, reason] for lam, reason in self.unevaluated],
                "largest_gap": float(self.largest_gap), "size": self._size,
                "counts": None if self.last is None else [int(c) for c in self.last.counts]}

    def restore(self, state: Mapping[str, Any]) -> None:
        """Take up a :meth:`state` (a resumed run goes on as the interrupted one would have)."""
        self.evaluations, self.confirmations = int(state["evaluations"]), int(state["confirmations"])
        for name in ("disagreements", "marginal_disagreements", "ambiguous_points", "fallbacks"):
            setattr(self, name, [float(v) for v in state[name]])
        self.unevaluated = [(float(lam), str(reason)) for lam, reason in state["unevaluated"]]
        self.largest_gap = float(state["largest_gap"])
        self._size = None if state["size"] is None else int(state["size"])
        self.last, self._last_key = None, None
        self._restored_counts = None if state["counts"] is None else tuple(int(c) for c in state["counts"])

    def report(self, branch) -> str:
        """Warn once per kind where Hill's verdict was replaced on ``branch``; the text for its message.

        Counts the points of ``branch`` (its ``point_data`` ``disagreement`` and
        ``hill_fallback``), not the evaluations (rejected steps and the location
        of special points are not points of the branch), and names the ranges
        of the parameter they make up (:func:`replaced_ranges`). Each kind
        found raises one :class:`~contin.util.warning.ContinWarning`.

        Parameters
        ----------
        branch : Branch
            A branch traced with this monitor.

        Returns
        -------
        str
            ``""`` when Hill's verdict was kept everywhere, else one clause per
            kind (``"stability: Hill's multipliers disagreed with the
            monodromy's on the stability at 12 of the branch's 186 points
            (w in [0.5, 0.61]); ..."``).
        """
        name = branch.parameter_name
        clauses = []
        for key, what, first, advice in (
                ("disagreement", "Hill's multipliers disagreed with the monodromy's on the stability",
                 self._first_disagreement, "check the harmonics H and stability steps_per_period"),
                ("hill_fallback", "Hill's multipliers disagreed with the monodromy's near +-1 (beyond "
                 f"agreement {self.options.agreement:g})", self._first_fallback, "check the harmonics H")):
            count, ranges = replaced_ranges(branch, key)
            if not count:
                continue
            text = (f"{what} at {count} of the branch's {len(branch)} points ({describe_ranges(name, ranges)}); "
                    f"the monodromy's multipliers were used there")
            # the first one's figures, where it is a point of the branch (not a rejected step)
            shown = first is not None and any(lo <= first[0] <= hi for lo, hi in ranges)
            warnings.warn(f"{text}{f' (first: {first[1]})' if shown else ''}; {advice}", ContinWarning, stacklevel=2)
            clauses.append(text)
        self._first_disagreement = self._first_fallback = None
        return "; ".join(f"stability: {c}" for c in clauses)

    def reset(self) -> None:
        """Forget the remembered verdict (before tracing a new branch)."""
        self._restored_counts = None
        self.last = None
        self._last_key = None

    def statistics(self) -> dict:
        return {
            "evaluations": self.evaluations,
            "confirmations": self.confirmations,
            "disagreements": list(self.disagreements),
            "marginal_disagreements": list(self.marginal_disagreements),
            "ambiguous_points": list(self.ambiguous_points),
            "fallbacks": list(self.fallbacks),
            "unevaluated": [[lam, reason] for lam, reason in self.unevaluated],
            "largest_hill_monodromy_gap": float(self.largest_gap),
            "method": self.options.method.value,
        }


def replaced_ranges(branch, key="disagreement") -> tuple[int, list[tuple[float, float]]]:
    """The points of ``branch`` flagged ``key`` in its ``point_data``, and the parameter ranges they make up.

    Consecutive flagged points along the branch make one range (its least
    and greatest parameter); ranges that overlap (a branch that folds back)
    are merged.

    Parameters
    ----------
    branch : Branch
    key : str or tuple of str
        A boolean column of ``branch.point_data``: ``"disagreement"`` or ``"hill_fallback"``;
        with several, a point flagged in any of them counts once.

    Returns
    -------
    count : int
        Flagged points of the branch (at most ``len(branch)``).
    ranges : list of (float, float)
        Sorted, disjoint ``(lo, hi)``; ``lo == hi`` for a lone point.

    Examples
    --------
    A branch at w = 0.5, 0.6, 0.7, 0.8 flagged at the first two and the last
    point gives ``(3, [(0.5, 0.6), (0.8, 0.8)])``.
    """
    data = branch.point_data
    columns = [data[k] for k in ((key,) if isinstance(key, str) else key) if k in data]
    if not columns or not len(branch):
        return 0, []
    flags = np.any([np.asarray(c, dtype=bool).reshape(len(branch)) for c in columns], axis=0)
    lam = np.asarray(branch.parameter, dtype=float)
    runs, start = [], None
    for i, f in enumerate([*flags, False]):  # a sentinel closes the last run
        if f and start is None:
            start = i
        elif not f and start is not None:
            runs.append((float(lam[start:i].min()), float(lam[start:i].max())))
            start = None
    merged: list[tuple[float, float]] = []
    for lo, hi in sorted(runs):
        if merged and lo <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], hi))
        else:
            merged.append((lo, hi))
    return int(flags.sum()), merged


def describe_ranges(name: str, ranges, limit: int = 4) -> str:
    """``"w in [0.5, 0.61] and [1.2, 1.25], w=1.7"``: ranges of a parameter in words (the first ``limit`` named)."""
    spans = [f"[{lo:.6g}, {hi:.6g}]" for lo, hi in ranges if hi > lo][:limit]
    points = [f"{lo:.6g}" for lo, hi in ranges if hi <= lo][:max(limit - len(spans), 0)]
    parts = ([f"{name} in " + ", ".join(spans)] if spans else []) + (
        [f"{name}=" + ", ".join(points)] if points else [])
    rest = len(ranges) - len(spans) - len(points)
    return "; ".join(parts) + (f" and {rest} more range(s)" if rest > 0 else "")
