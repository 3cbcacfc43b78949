"""Gathering solves whose kernel projection runs on a Ray cluster.

The driver plans the solve (:func:`wavrad.plan`), Ray actors project its
items in blocks, and the driver finishes it from their links
(:meth:`wavrad.Plan.finish`): the solution is that of :func:`wavrad.solve`
bit for bit. Each actor loads the scene from its path and builds a
:class:`wavrad.Projector` of it; the driver sends it each block's items
(``replan=True`` instead has every actor plan the scene again and sends it
only the blocks' ranges: the linking is then repeated by every worker).
Fingerprints of the scene, the settings and the plan, which every block
carries, make sure the workers project what the driver planned. Ray is an
optional dependency: ``pip install "wavrad[distributed]"``.

>>> import ray, wavrad.distributed
>>> ray.init()  # or ray.init(address="auto") to join a running cluster
>>> solution = wavrad.distributed.solve("scene.xml", workers=8, threshold=1e-3)

Every worker needs the scene's files at the same path (a shared file system,
or Ray's ``runtime_env={"working_dir": ...}``). ``docs/distributed.md`` has
the measurements and the limits.
"""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Mapping
from types import TracebackType
from typing import TYPE_CHECKING, Any

import wavrad

if TYPE_CHECKING:
    from typing_extensions import Self

__all__ = ["Projectors", "solve"]


def _ray() -> Any:
    try:
        import ray
    except ImportError as e:
        raise ImportError('wavrad.distributed needs Ray: pip install "wavrad[distributed]"') from e
    return ray


class _Worker:
    """One worker: a projector of the scene, sent blocks' items, or with
    ``replan`` a plan of it made again, sent blocks' ranges."""

    def __init__(
        self,
        path: str,
        defines: Mapping[str, object],
        settings: Mapping[str, Any],
        replan: bool,
    ) -> None:
        scene = wavrad.load_scene(path, **defines)
        made = wavrad.plan if replan else wavrad.projector
        self.projector: wavrad.Plan | wavrad.Projector = made(scene, **settings)

    def fingerprint(self) -> tuple[int, str]:
        return self.projector.fingerprint, platform.node()

    def cpu_seconds(self) -> float:
        return time.process_time()

    def project(self, block: Any) -> bytes:
        return self.projector.project(block)


class Projectors:
    """``workers`` Ray actors, spread over the cluster's nodes, each holding
    a projector (or, with ``replan``, a plan) of the scene at
    ``scene_path`` (loaded with ``defines``) with the settings of ``plan``,
    and projecting blocks on ``cpus_per_worker`` threads (default: the
    cluster's CPUs shared equally). Raises ``wavrad.SolveError`` if a
    worker's scene or settings are not the driver's (other scene files on
    its node, another wavrad). Use as a context manager, or call
    :meth:`close`.
    """

    def __init__(
        self,
        plan: wavrad.Plan,
        scene_path: str | os.PathLike[str],
        *,
        workers: int,
        cpus_per_worker: int | None = None,
        defines: Mapping[str, object] | None = None,
        replan: bool = False,
    ) -> None:
        ray = _ray()
        if workers < 1:
            raise ValueError(f"workers must be at least 1, got {workers}")
        if cpus_per_worker is None:
            cpus = int(ray.cluster_resources().get("CPU", 1))
            cpus_per_worker = max(1, cpus // workers)
        self.replan = replan
        remote = ray.remote(_Worker).options(
            num_cpus=cpus_per_worker,
            scheduling_strategy="SPREAD",
            runtime_env={"env_vars": {"RAYON_NUM_THREADS": str(cpus_per_worker)}},
        )
        path = os.fspath(scene_path)
        self.actors = [
            remote.remote(path, dict(defines or {}), plan.settings, replan) for _ in range(workers)
        ]
        expected = plan.fingerprint if replan else plan.projector_fingerprint
        try:
            for fingerprint, node in ray.get([a.fingerprint.remote() for a in self.actors]):
                if fingerprint != expected:
                    raise wavrad.SolveError(
                        f"the worker on {node} made {path} differently from the driver "
                        f"(fingerprint {fingerprint:08x}, the driver's {expected:08x}): "
                        "its scene files or its wavrad differ"
                    )
        except BaseException:
            self.close()
            raise

    def project(self, plan: wavrad.Plan, blocks_per_worker: int = 4) -> list[bytes]:
        """The links of every item of ``plan``, in ``blocks_per_worker``
        blocks per worker, handed to whichever worker is free."""
        from ray.util import ActorPool

        blocks = plan.blocks(len(self.actors) * blocks_per_worker)
        pool = ActorPool(self.actors)

        def submit(actor: Any, block: range) -> Any:
            return actor.project.remote(block if self.replan else plan.items(block))

        return list(pool.map_unordered(submit, blocks))

    def cpu_seconds(self) -> list[float]:
        """The CPU seconds each worker's process has used so far: how many
        cores the workers really got, against the wall-clock time."""
        return _ray().get([actor.cpu_seconds.remote() for actor in self.actors])

    def close(self) -> None:
        """End the workers."""
        ray = _ray()
        for actor in self.actors:
            ray.kill(actor)
        self.actors = []

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()


def solve(
    scene_path: str | os.PathLike[str],
    *,
    workers: int,
    cpus_per_worker: int | None = None,
    blocks_per_worker: int = 4,
    defines: Mapping[str, object] | None = None,
    replan: bool = False,
    **settings: Any,
) -> wavrad.Solution:
    """Solve the scene at ``scene_path`` (loaded with ``defines``, as
    :func:`wavrad.load_scene`'s keyword arguments) with the settings of
    :func:`wavrad.solve`, its kernels projected by ``workers`` Ray actors
    (:class:`Projectors`) and the system solved here. Uses the Ray cluster
    this process is connected to (Ray starts a local one if none)."""
    scene = wavrad.load_scene(scene_path, **(defines or {}))
    plan = wavrad.plan(scene, **settings)
    with Projectors(
        plan,
        scene_path,
        workers=workers,
        cpus_per_worker=cpus_per_worker,
        defines=defines,
        replan=replan,
    ) as projectors:
        blocks = projectors.project(plan, blocks_per_worker)
    return plan.finish(blocks)
