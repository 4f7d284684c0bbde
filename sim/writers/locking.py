"""Advisory locks (``fcntl.flock``) on output folders and cache entries, naming the process that holds one.

A lock is a small file that is never deleted (deleting it would let two processes lock two different
files under one name); the holder writes its process id into it, and empties it on release. The
operating system drops the lock when the holder exits, however it exits (Ctrl-C, kill -9), so a
stale lock never blocks anybody: a pid left in the file by a killed holder is ignored.

* :meth:`FolderLock.acquire` with ``wait=False`` (``generate --out``): a second writer does not wait;
  it gets a :class:`FolderBusy` (exit 2) naming the folder and the holder's pid.
* ``wait=True`` (the scenario cache): a second writer waits for the first (``on_wait(pid)`` is called
  once, to say so) and then finds its finished result.
"""
from __future__ import annotations

import fcntl
import os
import time
from pathlib import Path
from typing import Callable, Optional

from sim.errors import SimError

LOCK_NAME = ".vo-testbed.lock"          # inside an output folder


class FolderBusy(SimError):
    """Another process holds the lock (``pid``: its process id, None when it could not be read)."""

    def __init__(self, message: str, pid: Optional[int]):
        super().__init__(message)
        self.pid = pid


def holder_pid(lock_path) -> Optional[int]:
    """The pid written in ``lock_path`` (None when empty, unreadable or not a number)."""
    try:
        text = Path(lock_path).read_text().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


class FolderLock:
    """An exclusive advisory lock on ``lock_path`` (created when missing; its folder must exist).

    ``what`` names the locked thing in messages (e.g. the output folder). Use as a context manager
    after :meth:`acquire`, or call :meth:`release`; the lock is re-entrant within one object only.
    """

    def __init__(self, lock_path, what: str):
        self.path = Path(lock_path)
        self.what = what
        self._fd: Optional[int] = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def acquire(self, wait: bool, on_wait: Optional[Callable[[Optional[int]], None]] = None) -> "FolderLock":
        """Take the lock. ``wait=False``: raise :class:`FolderBusy` when another process holds it;
        ``wait=True``: call ``on_wait(pid)`` once, then block until it is free."""
        if self._fd is not None:
            return self
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise SimError(f"{self.what}: cannot create the lock file {self.path} ({e.strerror})") from None
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                pid = self._read_holder()
                if not wait:
                    who = f"process {pid}" if pid is not None else "another process"
                    raise FolderBusy(f"{self.what}: {who} is writing it (lock {self.path}); wait for it to "
                                     f"finish, or choose another folder", pid) from None
                if on_wait is not None:
                    on_wait(pid)
                fcntl.flock(fd, fcntl.LOCK_EX)
            except OSError as e:              # a file system without locks (some network mounts)
                raise SimError(f"{self.what}: cannot lock {self.path} ({e.strerror or e}); this file system "
                               f"does not support advisory locks, choose a local folder") from None
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        return self

    def _read_holder(self) -> Optional[int]:
        """The holder's pid; it writes it right after locking, so an empty file is read again briefly."""
        for _ in range(20):
            pid = holder_pid(self.path)
            if pid is not None:
                return pid
            time.sleep(0.05)
        return None

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            os.ftruncate(self._fd, 0)
        except OSError:
            pass
        fcntl.flock(self._fd, fcntl.LOCK_UN)
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> "FolderLock":
        return self

    def __exit__(self, *exc) -> None:
        self.release()
