"""What ``summary.json`` says of each branch of a frequency response: its conditioning and its stability."""

from __future__ import annotations

import numpy as np

from contin.stability.monitor import describe_ranges, replaced_ranges

__all__ = ["condition_summary", "interval_or_none", "stability_summary"]


def interval_or_none(gap):
    """``[lo, hi]`` as floats, or None."""
    return None if gap is None else [float(gap[0]), float(gap[1])]


def _finite_or_none(v):
    return float(v) if v is not None and np.isfinite(v) else None


def condition_summary(branch) -> dict:
    """Largest and last condition estimates of the scaled bordered Newton Jacobian (None if singular/absent)."""
    info = branch.info
    return {"max": _finite_or_none(info.get("max_condition")),
            "max_at": _finite_or_none(info.get("max_condition_parameter")),
            "last": _finite_or_none(info.get("last_condition"))}


def stability_summary(branch) -> dict | None:
    """Where Hill's multipliers were replaced by the monodromy's, and why (a shooting branch: its method only)."""
    st = branch.info.get("stability")
    if not st:
        return None
    out = {"method": st.get("method"),
           "hill_monodromy_gap": st.get("largest_hill_monodromy_gap"),
           # points of the branch (the statistics count every evaluation: rejected steps and locations too)
           "fallbacks": replaced_ranges(branch, "hill_fallback")[0],
           "disagreements": replaced_ranges(branch, "disagreement")[0],
           "unevaluated": len(st.get("unevaluated", []))}
    if st.get("unevaluated"):
        lam, why = st["unevaluated"][0]
        out["unevaluated_message"] = (f"no stability verdict at {len(st['unevaluated'])} points (first at "
                                      f"{lam:.10g}: {why}); their rows have empty stability cells")
    count, ranges = replaced_ranges(branch, ("disagreement", "hill_fallback"))
    if count:
        out["first_fallback_at"] = ranges[0][0]
        out["replaced_points"] = count
        out["replaced_ranges"] = [list(r) for r in ranges]
        out["message"] = (f"Hill and the monodromy disagreed at {count} of the branch's {len(branch)} points "
                          f"({describe_ranges(branch.parameter_name, ranges)}): the monodromy's multipliers were "
                          "used there")
    return out
