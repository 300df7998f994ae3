"""A climbing step's plan and preview in a worker process, so that climb_node and the nodes composed
with it keep their rate (docs/deployment.md).

:class:`StepWorker` runs :func:`.step_plan.plan_step` with the node's planner (sent once, when the
child starts) and :func:`.step_preview.run_preview` anchored on the odometry
(:func:`.odometry_attitude.anchor_phases`), one job at a time, and hands back the typed result.
No ROS import.
"""

from __future__ import annotations

from concurrent.futures import Future
from functools import partial

from rrps_climbing.gait import GaitPlanner
from rrps_climbing.odometry_attitude import anchor_phases
from rrps_climbing.plan import Phase
from rrps_climbing.step_io import PlanRequest, StepPlan
from rrps_climbing.step_plan import plan_step
from rrps_climbing.step_preview import PreviewConfig, run_preview, warm_up
from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_interfaces.climb import ClimbPreview
from rrps_runtime.worker import WorkerProcess

__all__ = ['StepWorker', 'load_kernels']

#: The child's planner (set when it starts).
_planner: GaitPlanner | None = None


def load_kernels(planner: GaitPlanner, request: PlanRequest, geometry: RobotGeometry, config: PreviewConfig) -> None:
    """Plan ``request`` once and load the preview's kernels: what the child does when it starts, so
    that its first step does not wait for them (the install's warm-up does it too, to compile them
    with the same argument types)."""
    plan_step(planner, request)
    warm_up(geometry, config)


def _start(planner: GaitPlanner, request: PlanRequest, geometry: RobotGeometry, config: PreviewConfig) -> None:
    """In the child: keep the planner and load the kernels."""
    global _planner
    _planner = planner
    load_kernels(planner, request, geometry, config)


def _plan(request: PlanRequest) -> StepPlan:
    return plan_step(_planner, request)


class StepWorker:
    """Plans and previews the steps of ``planner``'s robot one after the other in a child process;
    ``request`` is a plan made there at start, to load its kernels."""

    def __init__(self, planner: GaitPlanner, request: PlanRequest, geometry: RobotGeometry,
                 config: PreviewConfig):
        self.geometry, self.config = geometry, config
        # never in this process' interpreter; its kernels loaded there at start, not at the first step
        self._worker = WorkerProcess('climb_step', warm_up=partial(_start, planner, request, geometry, config))
        self._job: tuple[str, Future] | None = None

    def when_ready(self, callback) -> None:
        """``callback(seconds)`` once the child loaded its kernels (the first plan waits for it)."""
        self._worker.when_started(callback)

    def plan(self, request: PlanRequest) -> None:
        """Plan ``request``."""
        self._job = ('plan', self._worker.submit(_plan, request))

    def preview(self, phases: list[Phase], world_T_a: Pose | None, period: float) -> None:
        """Preview a step's ``phases`` streamed at ``period`` [s], where the odometry's ring_a
        stands (``world_T_a``; None: where the plan puts it)."""
        self._job = ('preview', self._worker.submit(run_preview, self.geometry, anchor_phases(phases, world_T_a),
                                                    period=period, config=self.config))

    def result(self) -> StepPlan | ClimbPreview | None:
        """The finished plan or preview, once (None while none finished); a job that raised
        refuses its step."""
        if self._job is None or not self._job[1].done():
            return None
        (kind, job), self._job = self._job, None
        try:
            return job.result()
        except Exception as exc:  # noqa: BLE001 - a job that raised refuses its step, logged
            failed = f'{kind} failed: {type(exc).__name__}: {exc}'
            if kind == 'plan':
                return StepPlan(refusal=failed)
            return ClimbPreview(accepted=False, max_force=float(self.geometry.max_force), detail=failed)

    def shutdown(self) -> None:
        """End the child (a running job is abandoned)."""
        self._worker.shutdown()
