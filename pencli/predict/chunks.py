"""A sweep's designs worked through in chunks: local threads or a dask cluster, results in order.

Chunks are made as they are needed (a few in flight at a time), so memory does not grow with the sweep.
The compiled batch simulator releases the GIL, so local threads use every core without copying chunks
between processes.  Files and progress bars stay with the caller (``pencli.api.sweep``).
"""

from __future__ import annotations

from typing import Callable

from pencli.errors import ParameterError

CHUNK = 100_000
"""Designs per chunk: bounded memory (~0.2 GB a chunk in flight) whatever the sweep's size."""


def run_chunk(base: dict, columns: dict) -> dict:
    """One chunk (varied columns, file units) through the batch simulator: CONTRACT §5 figures, with ``end``
    as codes into :data:`pencli.predict.batch.ENDS` (int8) and ``near_critical`` (an arrest whose time is
    round-off).  Top level, so dask can ship it."""
    from pencli.predict.batch import simulate_batch
    from pencli.predict.sweep import si_designs

    designs, speed = si_designs(base, columns)
    result = simulate_batch(designs, speed_at_contact_m_s=speed)
    return {**result.figures, "end": result.code, "near_critical": result.near_critical}


def _take_and_run(base: dict, columns, start: int, stop: int, runner=run_chunk) -> tuple[dict, dict]:
    """Designs ``start`` to ``stop`` of ``columns`` made and simulated in the worker: the caller's thread
    only writes."""
    chunk = columns.take(start, stop)
    return chunk, runner(base, chunk)


def evaluate_columns(base: dict, columns, *, engine: str = "local", scheduler: str | None = None,
                     workers: int = 2, progress: Callable[[int, int], None] | None = None,
                     runner: Callable[[dict, dict], dict] = run_chunk, chunk_size: int = CHUNK):
    """Yield (chunk columns, results) in order; local threads or a dask cluster do the work.

    ``runner(base, chunk)`` simulates one chunk (default :func:`run_chunk`, the batch simulator; a penetrator
    outside Eq. 9's form passes :func:`pencli.predict.shapes.run_chunk_shaped`), ``chunk_size`` designs at a time.

    ``columns``: a :class:`~pencli.predict.sweep.Grid` or :class:`~pencli.predict.sweep.Sample`, whose chunks
    are made as they are needed (a few in flight at a time, so memory does not grow with the sweep).
    """
    n, take = columns.size, columns.take
    chunks = (take(s, min(s + chunk_size, n)) for s in range(0, n, chunk_size))
    done = 0

    def emit(chunk: dict, result: dict) -> tuple[dict, dict]:
        nonlocal done
        done += len(next(iter(chunk.values())))
        if progress:
            progress(done, n)
        return chunk, result

    if engine == "dask":
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            raise ParameterError("--engine dask needs the dask extra: pip install 'pen[dask]'") from None
        cluster = None if scheduler else LocalCluster(n_workers=workers, threads_per_worker=1, processes=False,
                                                      dashboard_address=None)
        client = Client(scheduler or cluster)
        try:
            chunks = list(chunks)
            futures = client.map(runner, [base] * len(chunks), chunks, pure=False)
            for chunk, future in zip(chunks, futures):
                yield emit(chunk, future.result())
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
        return
    if engine != "local":
        raise ParameterError(f"--engine {engine!r}: expected local or dask")
    if n <= chunk_size or workers <= 1:
        for chunk in chunks:
            yield emit(chunk, runner(base, chunk))
        return
    from collections import deque
    from concurrent.futures import ThreadPoolExecutor

    # threads, not processes: the simulator's loops are compiled and release the GIL, and nothing is
    # copied between processes; the caller writes each finished chunk while the next ones run
    with ThreadPoolExecutor(max_workers=workers) as pool:
        pending: deque = deque()  # at most 2 × workers chunks in flight
        for start in range(0, n, chunk_size):
            pending.append(pool.submit(_take_and_run, base, columns, start, min(start + chunk_size, n), runner))
            if len(pending) >= 2 * workers:
                yield emit(*pending.popleft().result())
        while pending:
            yield emit(*pending.popleft().result())


__all__ = ["CHUNK", "evaluate_columns", "run_chunk"]
