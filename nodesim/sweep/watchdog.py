"""Parent watchdog of a local sweep pool: when the driver dies, however it dies, its pool dies with it.

A ``kill -9`` of ``nodesim sweep`` gives the driver no chance to shut its process pool down: the fork
server, the workers (blocked on a queue whose write end they hold themselves) and multiprocessing's
resource tracker were re-parented to PID 1 and kept running, and multiprocessing's temporary directory
(``pymp-*``, the fork server's socket) stayed behind.  So the driver, before its pool starts, marks its
environment with a per-process token (``NODESIM_POOL_TOKEN``, inherited by every process the pool starts:
the fork server and resource tracker are exec'ed from the driver, the workers forked from the server) and
starts this watchdog in its own session with a pipe.  The watchdog blocks reading the pipe; end of file
means the driver has exited (normally or not).  It then SIGKILLs every process whose initial environment
(``/proc/PID/environ``) carries the token and removes the temporary directories it was given.

Linux only (``/proc``); elsewhere :func:`start` does nothing and a normal exit still shuts the pool down.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import uuid
from pathlib import Path

TOKEN_VAR = "NODESIM_POOL_TOKEN"
_started: dict = {}


def start(temp_dirs: list[str]) -> str | None:
    """Start this process's watchdog once (idempotent) and mark the environment; returns the token."""
    if not sys.platform.startswith("linux") or not Path("/proc/self/environ").exists():
        return None
    if _started:
        for d in temp_dirs:
            if d not in _started["dirs"]:
                _started["dirs"].append(d)
                _started["proc"].stdin.write(f"dir {d}\n".encode())
                _started["proc"].stdin.flush()
        return _started["token"]
    token = uuid.uuid4().hex
    proc = subprocess.Popen(
        [sys.executable, "-c", "from nodesim.sweep.watchdog import main; main()", token, str(os.getpid())],
        stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        start_new_session=True, close_fds=True, env={k: v for k, v in os.environ.items() if k != TOKEN_VAR},
    )
    for d in temp_dirs:
        proc.stdin.write(f"dir {d}\n".encode())
    proc.stdin.flush()
    _started.update(token=token, proc=proc, dirs=list(temp_dirs))
    os.environ[TOKEN_VAR] = token
    return token


def marked_processes(token: str, exclude: set[int]) -> list[int]:
    """PIDs whose initial environment holds ``NODESIM_POOL_TOKEN=token`` (other than ``exclude``)."""
    needle = f"{TOKEN_VAR}={token}".encode()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) in exclude:
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as fh:
                if needle in fh.read().split(b"\0"):
                    found.append(int(entry))
        except OSError:
            continue
    return found


def main() -> None:
    """Watchdog process: ``argv = [token, driver_pid]``; lines ``dir PATH`` on stdin; act on end of file."""
    token = sys.argv[1]
    dirs = []
    for line in sys.stdin.buffer:
        text = line.decode(errors="replace").rstrip("\n")
        if text.startswith("dir "):
            dirs.append(text[4:])
    me = {os.getpid()}
    for _ in range(3):  # a worker might be forking while we look; look again
        pids = marked_processes(token, me)
        if not pids:
            break
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
    for d in dirs:
        shutil.rmtree(d, ignore_errors=True)


__all__ = ["TOKEN_VAR", "main", "marked_processes", "start"]
