"""Process pools whose worker processes exit by themselves when the process that started them dies.

A ``concurrent.futures.ProcessPoolExecutor`` cleans up its workers when its parent exits normally or on an
exception, but not when the parent is killed (``kill -9``, the OOM killer, a closed terminal's SIGKILL): the
workers then wait on their call queue forever (three orphans of ~115 MB each per killed ``hacgear statics``).
:func:`process_pool` gives each worker a daemon thread that checks every ``period_s`` whether its parent is
still there and ends the worker (``os._exit``) when it is not.  Used by ``hacgear statics`` and
``hacgear sweep``; any other pool of the library should come from here too.  :func:`executor_slots` says how many
tasks an executor runs at once (the sweeps size their batched tasks by it).
"""
from __future__ import annotations

import multiprocessing
import os
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Callable

__all__ = ["process_pool", "executor_slots", "ORPHAN_EXIT_STATUS"]

#: exit status of a worker that ended because its parent died
ORPHAN_EXIT_STATUS = 70

#: warning filter handed to multiprocessing's resource tracker: after a killed parent the tracker unlinks the pool's
#: semaphores itself and then warns "There appear to be N leaked semaphore objects" on the user's terminal, about a
#: clean-up that succeeded.  The tracker is started with this interpreter's -W options (sys.warnoptions).
_TRACKER_QUIET = "ignore:resource_tracker:UserWarning"


def _quiet_resource_tracker() -> None:
    """Make the resource tracker (started with the first pool's first lock) silent about what it cleans up."""
    if _TRACKER_QUIET not in sys.warnoptions:
        sys.warnoptions.append(_TRACKER_QUIET)


def _parent_alive(parent_pid: int, reparent_check: bool) -> bool:
    if reparent_check:  # the worker is the parent's child: the kernel re-parents it the moment the parent dies
        return os.getppid() == parent_pid
    try:  # started through an intermediary (forkserver): ask the kernel whether the pid exists
        os.kill(parent_pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _watch(parent_pid: int, period_s: float) -> None:
    reparent_check = os.getppid() == parent_pid
    while True:
        time.sleep(period_s)
        if not _parent_alive(parent_pid, reparent_check):
            os._exit(ORPHAN_EXIT_STATUS)


def _init_worker(parent_pid: int, period_s: float, initializer: Callable[..., Any] | None,
                 initargs: tuple) -> None:
    threading.Thread(target=_watch, args=(parent_pid, period_s), name="hacgear-parent-watch", daemon=True).start()
    if initializer is not None:
        initializer(*initargs)


def process_pool(max_workers: int | None = None, *, mp_context: Any = None, start_method: str | None = None,
                 initializer: Callable[..., Any] | None = None, initargs: tuple = (),
                 period_s: float = 0.25) -> ProcessPoolExecutor:
    """A ``ProcessPoolExecutor`` whose workers end within ``period_s`` [s] (plus the time the current call
    holds the GIL) after the process that created the pool dies.

    Parameters
    ----------
    max_workers : int, optional
        Worker processes (default: CPU count).
    mp_context, start_method : optional
        A multiprocessing context, or the name of a start method (``"spawn"``, ``"fork"``, ``"forkserver"``).
    initializer, initargs : optional
        Run in each worker after the watchdog has started (as in ``ProcessPoolExecutor``).
    period_s : float
        Polling period of the watchdog [s].
    """
    if mp_context is None and start_method is not None:
        mp_context = multiprocessing.get_context(start_method)
    _quiet_resource_tracker()
    return ProcessPoolExecutor(max_workers=max_workers, mp_context=mp_context, initializer=_init_worker,
                               initargs=(os.getpid(), float(period_s), initializer, tuple(initargs)))


def executor_slots(executor: Any) -> int | None:
    """How many tasks ``executor`` runs at once: a ``ProcessPoolExecutor``'s worker processes, a Dask
    ``Client.get_executor()``'s worker threads over the cluster; None for any other executor (unknown)."""
    if isinstance(executor, ProcessPoolExecutor):
        return int(executor._max_workers)
    client = getattr(executor, "_client", None)
    if client is not None and hasattr(client, "nthreads"):
        try:
            return max(1, int(sum(client.nthreads().values())))
        except Exception:  # a client that cannot answer (closed, not connected): unknown
            return None
    return None
