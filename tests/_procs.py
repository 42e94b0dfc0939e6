"""Test helpers: the live processes of a session (Linux /proc), and waiting for them to end."""
from __future__ import annotations

import os
import signal
import time
from pathlib import Path


def session_processes(sid: int) -> list[tuple[int, str]]:
    """(pid, command) of every live (not zombie) process in session ``sid`` (Linux /proc)."""
    out = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if fields[0] != "Z" and int(fields[3]) == sid:
            out.append((int(d.name), cmd))
    return out


def wait_for_no_orphans(sid: int, timeout_s: float = 10.0) -> list[tuple[int, str]]:
    """Wait until session ``sid`` has no live process left; returns the survivors (after SIGKILLing them)."""
    t0 = time.monotonic()
    left = session_processes(sid)
    while left and time.monotonic() - t0 < timeout_s:
        time.sleep(0.1)
        left = session_processes(sid)
    for pid, _ in left:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    return left


def kill_when(proc, ready, timeout_s: float = 240.0, period_s: float = 0.02) -> list[tuple[int, str]]:
    """SIGKILL the main process of ``proc`` (a ``subprocess.Popen`` started with ``start_new_session=True``) as soon
    as ``ready()`` returns True (``OSError``/``KeyError`` while it reads a file being written count as not ready),
    or at ``timeout_s``; wait for it and return the processes of its session left behind (killed)."""
    t0 = time.monotonic()
    try:
        while time.monotonic() - t0 < timeout_s and proc.poll() is None:
            time.sleep(period_s)
            try:
                if ready():
                    break
            except (OSError, KeyError):
                continue
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    return wait_for_no_orphans(proc.pid)
