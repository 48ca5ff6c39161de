"""The step limits of a shooting branch through grazing corners.

Where a contact arc of an orbit appears or vanishes (grazing), the flow map
of the integrator with located switches stays continuous but its derivative
changes (:mod:`contin.timedomain.shooting_events`): the branch of orbits has
a corner, or, for a soft contact, a point where its tangent turns fast over
a short arc. A branch that passes such corners, one after another where a
bouncing contact grazes in a cascade, needs a larger turn per step and more
points before its advance counts as a crawl than a smooth branch.
"""

from __future__ import annotations

__all__ = ["GRAZING_STALL", "GRAZING_TURN", "through_grazing"]

#: the turn (degrees) a step of a shooting branch may take: at a grazing point of a soft contact the flow map is
#: C^1 with a 3/2-power term, so the tangent turns fast over a short arc (the chord test still guards the steps)
GRAZING_TURN = 60.0
#: the stored points a shooting branch may take to advance ``ds_max`` before it counts as a crawl: through a
#: cascade of grazing corners (a bouncing bearing) it advances slowly but steadily, far above ds_min
GRAZING_STALL = 200


def through_grazing(options):
    """``options`` (:class:`~contin.engine.options.ContinuationOptions`) with turns up to :data:`GRAZING_TURN`
    and :data:`GRAZING_STALL` points before a crawl, where they allowed less."""
    return options.replace(max_angle_deg=max(options.max_angle_deg, GRAZING_TURN),
                           stall_points=max(options.stall_points, GRAZING_STALL))
