"""A climbing step's preview in a worker process, so climb_node keeps its rate (docs/deployment.md).

:class:`PreviewWorker` runs :func:`.step_preview.run_preview` anchored on the odometry
(:func:`.odometry_attitude.anchor_phases`) and returns a :class:`~rrps_interfaces.climb.ClimbPreview`.
"""

from __future__ import annotations

from concurrent.futures import Future
from functools import partial

from rrps_climbing.odometry_attitude import anchor_phases
from rrps_climbing.plan import Phase
from rrps_climbing.step_preview import PreviewConfig, run_preview, warm_up
from rrps_description.geometry import RobotGeometry
from rrps_description.pose import Pose
from rrps_interfaces.climb import ClimbPreview
from rrps_runtime.worker import WorkerProcess

__all__ = ['PreviewWorker']


class PreviewWorker:
    """Previews the submitted steps of ``geometry``'s robot one after the other in a child process."""

    def __init__(self, geometry: RobotGeometry, config: PreviewConfig):
        self.geometry, self.config = geometry, config
        # never in this process' interpreter; its kernels loaded there at start, not at the first step
        self._worker = WorkerProcess('climb_preview', warm_up=partial(warm_up, geometry, config))
        self._job: Future | None = None

    def submit(self, phases: list[Phase], world_T_a: Pose | None, period: float) -> None:
        """Preview a step's ``phases`` streamed at ``period`` [s], where the odometry's ring_a
        stands (``world_T_a``; None: where the plan puts it)."""
        self._job = self._worker.submit(run_preview, self.geometry, anchor_phases(phases, world_T_a),
                                        period=period, config=self.config)

    def result(self) -> ClimbPreview | None:
        """The finished preview, once (None while none finished); one that raised refuses its step."""
        if self._job is None or not self._job.done():
            return None
        job, self._job = self._job, None
        try:
            return job.result()
        except Exception as exc:  # noqa: BLE001 - a preview that raised refuses its step, logged
            return ClimbPreview(accepted=False, max_force=float(self.geometry.max_force),
                                detail=f'preview failed: {type(exc).__name__}: {exc}')

    def shutdown(self) -> None:
        """End the child (a running preview is abandoned)."""
        self._worker.shutdown()
