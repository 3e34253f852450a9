"""The engines that run :func:`~svbrdf.runtime.batch.job.run_job` for the driver: a local process pool
(:class:`LocalEngine`, sized by :func:`plan_workers`) or Ray tasks (:class:`RayEngine`)."""

from __future__ import annotations

from typing import Any, Callable, Dict, Iterator, Optional, Tuple

from ..errors import MissingExtraError, SvbrdfError
from .job import Job, _one_line, run_job

__all__ = ["plan_workers", "LocalEngine", "RayEngine"]


def _top_up(pending: Dict[Any, "Job"], jobs: Iterator["Job"], capacity: int, submit: Callable[["Job"], Any]) -> bool:
    """Submit jobs (``pending[submit(job)] = job``) until ``capacity`` are in flight; True once ``jobs`` ran out."""
    while len(pending) < capacity:
        job = next(jobs, None)
        if job is None:
            return True
        pending[submit(job)] = job
    return False


def plan_workers(cores: int, workers: Optional[int], threads: Optional[int], gpu: bool = False) -> Tuple[int, int]:
    """``(workers, threads per worker)`` of the local pool: ``--workers`` and ``--threads`` when given, the other
    one from the cores (``cores // workers`` threads, ``cores // threads`` workers); by default one thread per
    core-worker, or one worker with every core when the refine runs on a GPU (one photo at a time)."""
    cores = max(1, cores)
    if workers and threads:
        return workers, threads
    if workers:
        return workers, max(1, cores // workers)
    if threads:
        return max(1, cores // threads), threads
    return (1, cores) if gpu else (cores, 1)


class LocalEngine:
    """Runs jobs in this process (``workers == 1``) or in a pool of ``workers`` spawned processes."""

    def __init__(self, workers: int):
        self.workers = workers
        self.capacity = 1 if workers == 1 else 2 * workers
        self._pool = None

    def __enter__(self) -> "LocalEngine":
        return self

    def _new_pool(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        # spawn, not fork: onnxruntime's and torch's thread pools do not survive a fork.
        return ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"))

    def run(self, jobs: Iterator[Job]) -> Iterator[Tuple[Job, Dict[str, Any]]]:
        """Yield ``(job, result)`` as jobs finish, keeping at most :attr:`capacity` in flight."""
        if self.workers == 1:
            for job in jobs:
                yield job, run_job(job)
            return
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        self._pool = self._new_pool()
        pending: Dict[Any, Job] = {}
        jobs = iter(jobs)
        exhausted = False
        while True:
            exhausted = exhausted or _top_up(pending, jobs, self.capacity, lambda j: self._pool.submit(run_job, j))
            if not pending:
                return
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            broken = False
            for fut in finished:
                job = pending.pop(fut)
                try:
                    result = fut.result()
                except BrokenProcessPool:
                    broken = True
                    result = _died(job, "a worker process died (out of memory?)")
                except Exception as exc:  # the job could not be sent or its result not returned
                    result = _died(job, _one_line(exc))
                yield job, result
            if broken:  # every job in flight is lost with the pool: report them, go on with a new pool
                for fut, job in pending.items():
                    yield job, _died(job, "a worker process died (out of memory?)")
                pending.clear()
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = self._new_pool()

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=exc[0] is None, cancel_futures=True)


def _died(job: Job, why: str) -> Dict[str, Any]:
    return {"name": job.name, "status": "failed", "error": f"{job.source}: {why}", "timings": {}}


def _import_ray():
    try:
        import ray
    except ImportError:
        from ..install import install_command

        raise MissingExtraError(f"--ray needs Ray: {install_command('cluster')}") from None
    return ray


class RayEngine:
    """Runs jobs as Ray tasks (``num_cpus`` = threads, ``num_gpus`` = gpus) on the cluster at ``address``
    (``None``: a new local Ray instance; ``"auto"``: the cluster this machine belongs to), or on the Ray instance
    this process already joined."""

    def __init__(self, address: Optional[str], threads: int, gpus: float = 0.0, local_cpus: Optional[int] = None):
        self.ray = _import_ray()
        self.started = False
        if not self.ray.is_initialized():
            kwargs = {"include_dashboard": False, "log_to_driver": False}
            if address is None and local_cpus:
                kwargs["num_cpus"] = local_cpus
            try:
                self.ray.init(address=address, **kwargs)
            except Exception as exc:  # a bad address, no cluster there
                raise SvbrdfError(f"cannot join the Ray cluster {address or '(local)'}: {_one_line(exc)}") from None
            self.started = True
        cpus = int(self.ray.cluster_resources().get("CPU", 1))
        self.capacity = max(1, 2 * (cpus // max(1, threads)))
        self.task = self.ray.remote(run_job).options(num_cpus=threads, num_gpus=gpus or 0, max_retries=0)

    def __enter__(self) -> "RayEngine":
        return self

    def run(self, jobs: Iterator[Job]) -> Iterator[Tuple[Job, Dict[str, Any]]]:
        """Yield ``(job, result)`` as tasks finish, keeping at most :attr:`capacity` in flight."""
        ray = self.ray
        pending: Dict[Any, Job] = {}
        jobs = iter(jobs)
        exhausted = False
        try:
            while True:
                exhausted = exhausted or _top_up(pending, jobs, self.capacity, self.task.remote)
                if not pending:
                    return
                ready, _ = ray.wait(list(pending), num_returns=1)
                for ref in ready:
                    job = pending.pop(ref)
                    try:
                        result = ray.get(ref)
                    except Exception as exc:  # the task's worker died, or the node
                        result = _died(job, f"Ray task failed ({_one_line(exc)})")
                    yield job, result
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)

    def __exit__(self, *exc) -> None:
        if self.started:
            self.ray.shutdown()
