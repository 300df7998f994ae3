"""The shipped routes (:mod:`.route`) as the climb node's step machine plans them.

:func:`route_planner`: ``facade_corner`` is the gait round the corner (half the reach per step);
``frame_route`` is :class:`RouteSteps`, each climb from and to both rings side by side on the
beams' face, the nodes crossed on the way. No ROS import.
"""

from __future__ import annotations

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.load_check import LoadCheck
from rrps_climbing.plan import ClimbPlan
from rrps_climbing.route import ROUTES, FrameRoutePlanner, frame_route
from rrps_description.corners import facade_corner
from rrps_description.geometry import RobotGeometry

__all__ = ['RouteSteps', 'route_planner', 'ROUTE_START']

#: Where ring_a stands at the start of a frame route [m] (both rings side by side on the column).
ROUTE_START = 0.3


class RouteSteps:
    """A frame route's climbs for the step machine (module docstring): the interface of a
    :class:`.gait.GaitPlanner` the machine uses (``structure``, ``sep_home``, ``default_step``,
    ``dof``, ``plan``, ``approach``, ``mounts``, ``world_rings``)."""

    def __init__(self, route: FrameRoutePlanner):
        self.route = route
        walker = route.walker
        self.geometry, self.structure, self.dof = route.geometry, route.face, route.dof
        self.sep_home = 0.0   # side by side
        self.default_step = route.stride
        self.mounts, self.world_rings, self.approach = walker.mounts, walker.world_rings, walker.approach

    def plan(self, distance: float, steps: int | None = None, *, start: float | None = None,
             initial_separation: float | None = None, initial_theta: float = 0.0) -> ClimbPlan:
        """A climb of ``distance`` [m] along the route from both rings side by side at ``start``
        (default :data:`ROUTE_START`); ``steps`` follow the route. ValueError for rings apart
        or an angle other than the route's there; the route's PlanError when a limit breaks."""
        start = ROUTE_START if start is None else float(start)
        if initial_separation not in (None, 0.0) and abs(initial_separation) > 1e-9:
            raise ValueError('a frame route is climbed from both rings side by side, '
                             f'not {initial_separation:.3f} m apart')
        if abs(initial_theta - self.route.theta_at(start)) > 1e-6:
            raise ValueError(f'the rings stand at {initial_theta:.4f} rad, the route at s={start:.3f} m '
                             f'at {self.route.theta_at(start):.4f} rad')
        return self.route.plan(distance, start=start)


def route_planner(geometry: RobotGeometry, route: str, *, loads: LoadCheck | None, corner_deg: float = 20.0,
                  bends_deg=(30.0, 30.0), use_extra_dof: bool = True, gravity=None):
    """The step machine's planner of the shipped route ``route`` (:data:`.route.ROUTES`)."""
    if route == 'facade_corner':
        kwargs = {} if loads is None else {'loads': loads}
        return GaitPlanner(geometry, facade_corner(corner_deg), use_extra_dof=use_extra_dof, step_fraction=0.5,
                           **kwargs)
    if route == 'frame_route':
        return RouteSteps(FrameRoutePlanner(geometry, frame_route(bends_deg), use_extra_dof=use_extra_dof,
                                            gravity=gravity))
    raise ValueError(f'unknown route {route!r}: one of {", ".join(ROUTES)}')
