"""How a frequency response gets its stability monitor, events and branch switching."""

from __future__ import annotations

from contin.continuation import continuation

__all__ = ["stability_setup"]


def stability_setup(analysis: dict, hb):
    """Monitors, events and the branch-following function for a scene's analysis.

    Returns
    -------
    monitors, events : tuple
    follow : callable
        ``follow(hb, u0, lam0, lam_range, options, recorder, ctx) -> [(Branch, meta)]``.
    """
    method = analysis["stability"]
    if method != "none" or analysis["switch"]:
        raise NotImplementedError("stability and switching are not available yet")

    def follow(hb, u0, lam0, lam_range, options, rec, ctx):
        def callback(branch, i):
            rec.point(0, hb.nu, branch, i, hb.H)
            ctx.progress.update(f"branch 0  {hb.parameter}={branch.parameter[i]:.6g}  point {i}  ds={branch.step_sizes[i]:.3g}")
            return not ctx.stop_requested

        br = continuation(hb, u0, lam0, lam_range, options, parameter_name=hb.parameter, callback=callback)
        rec.special_points(0, br)
        return [(br, {"nu": hb.nu})]

    return (), (), follow
