"""The run lock: one writer per results file, whatever name reaches it.

A run takes two locks before it reads or writes anything: ``<real path>.lock`` (``flock``, holding the
holder's pid, host and start time; it also covers a file that does not exist yet, and any name of
its folder, since the lock file is found in the folder itself), and an open-file-description lock
(``F_OFD_SETLK``) on the results file's own inode, which every hard link of the file shares.
"""
from __future__ import annotations

import errno
import fcntl
import json
import os
import socket
import stat
import struct
import time
import warnings
from pathlib import Path
from typing import Mapping

from pycolfrag.core.errors import ResultsFileError


class ResultsLockedError(ResultsFileError):
    """The results file is being written by another running grid (its lock is held)."""


def lock_path(path) -> Path:
    """The lock sidecar of a results file: ``<path>.lock``."""
    return Path(os.fspath(path) + ".lock")


def _holder_text(info: Mapping) -> str:
    return (f"pid {info.get('pid', '?')} on host {info.get('host', '?')}, started {info.get('started', '?')}"
            + (f" ({info['command']})" if info.get("command") else ""))


def _read_holder(fd: int) -> dict:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        data = os.read(fd, 1 << 16)
        return json.loads(data.decode("utf-8")) if data.strip() else {}
    except (OSError, ValueError, UnicodeDecodeError):
        return {}


def lock_held(results_path) -> bool:
    """Whether a run holds the lock of ``results_path`` now (its :class:`RunLock`), under this name or
    under another name of the same file (a hard link)."""
    try:
        fd = os.open(lock_path(results_path), os.O_RDONLY)
    except OSError:
        return _inode_locked(results_path)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
    except OSError:
        return True
    finally:
        os.close(fd)
    return _inode_locked(results_path)


# ---------------------------------------------------------------------------------------
# the file's own identity: an open-file-description lock on its inode
# ---------------------------------------------------------------------------------------

#: ``struct flock`` of 64-bit Linux: l_type, l_whence, l_start, l_len, l_pid, padding (32 bytes).
_FLOCK = "hhqqi4x"


def _flock_arg(kind: int) -> bytes:
    return struct.pack(_FLOCK, kind, os.SEEK_SET, 0, 0, 0)  # the whole file; l_pid 0 as OFD locks require


def _inode_locked(path) -> bool:
    """Whether some open file description holds the write lock of :func:`_lock_inode` on the file at ``path``."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
    except OSError:
        return False
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return False
        got = fcntl.fcntl(fd, fcntl.F_OFD_GETLK, _flock_arg(fcntl.F_RDLCK))
        return struct.unpack(_FLOCK, got)[0] != fcntl.F_UNLCK
    finally:
        os.close(fd)


def _lock_inode(path: Path) -> int | None:
    """Lock the inode of the regular file at ``path`` (``F_OFD_SETLK``, write lock on the whole file);
    return the descriptor that holds it, or None when there is no regular file there or this process
    may not write it (the run then fails at its first write, with that error).

    An open-file-description lock, not ``flock``: HDF5 readers opened with the library's default file
    locking take ``flock`` on the file, and they must be able to read it while a run writes (nothing
    of theirs conflicts with this lock); and not a process-wide POSIX lock, which the writer's own
    opening and closing of the file in every batch would release."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_NONBLOCK | os.O_NOCTTY)
    except (FileNotFoundError, IsADirectoryError, PermissionError):
        return None
    except OSError as exc:
        if exc.errno in (errno.EROFS, errno.ENXIO):
            return None
        raise
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            os.close(fd)
            return None
        fcntl.fcntl(fd, fcntl.F_OFD_SETLK, _flock_arg(fcntl.F_WRLCK))
    except (BlockingIOError, PermissionError):  # EAGAIN / EACCES: another description holds it
        st = os.fstat(fd)
        os.close(fd)
        raise ResultsLockedError(_identity_text(path, st)) from None
    except BaseException:
        os.close(fd)
        raise
    return fd


#: The lock refusal's advice for the grid; a command without ``--out`` (``risk --simulate``) puts its
#: own in its place (:func:`pycolfrag.risk.simulate`'s failure line).
OTHER_FILE = "use --out for another file"


def _identity_text(path: Path, st) -> str:
    holder = _holder_of_same_file(path, st)
    return (f"{path} is being written by another run under another name of the same file (device {st.st_dev}, "
            f"inode {st.st_ino}: a hard link){': ' + holder if holder else ''}. Two names of one file are one "
            f"file: wait for that run to end, or {OTHER_FILE}.")


def _holder_of_same_file(path: Path, st) -> str:
    """The holder of the path lock of another name of the same file in the same folder, if one is found
    there (a hard link elsewhere is not searched for)."""
    try:
        with os.scandir(path.parent) as it:
            for entry in it:
                if entry.path == os.fspath(path) or entry.name.endswith((".lock", ".journal")):
                    continue
                try:
                    if entry.inode() != st.st_ino or entry.stat(follow_symlinks=False).st_dev != st.st_dev:
                        continue
                    info = json.loads(lock_path(entry.path).read_text(encoding="utf-8"))
                except (OSError, ValueError, UnicodeDecodeError):
                    continue
                if isinstance(info, dict):
                    return f"{_holder_text(info)} (as {entry.name})"
    except OSError:
        pass
    return ""


def _pid_alive(pid) -> bool:
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except (PermissionError, TypeError, ValueError, OverflowError):
        return True
    return True


class RunLock:
    """Exclusive lock on a results file, held by the one process that writes it (rank 0).

    Two locks, both taken before anything is read or written:

    * ``<path>.lock`` is locked with ``flock(LOCK_EX | LOCK_NB)`` and holds JSON with the holder's pid,
      host and start time. It exists before the results file does, and any name of the folder reaches
      the same lock file. The kernel drops an flock when its process dies (also by SIGKILL), so a lock
      file that can be locked is stale: its former holder is gone, and the new run takes it over (and
      says so, with whether that pid still exists when it was on this host). A second run while the
      holder lives is refused with :class:`ResultsLockedError` naming the holder.
    * the results file's inode is write-locked (:func:`_lock_inode`), so a run given another name of the
      same file (a hard link) is refused too; :meth:`hold_file` locks the file again once the run has
      created or rebuilt it (a new inode).

    Neither lock protects across hosts on file systems without lock support (some NFS set-ups): there
    the pid/host in the lock file is still shown, but only the kernel's locks are enforced.
    """

    def __init__(self, path: Path, fd: int, info: dict, stale: dict | None):
        self._fd: int | None   # None once released
        self.path, self._fd, self.info, self.stale = path, fd, info, stale
        self._file_fds: list[int] = []

    @classmethod
    def acquire(cls, results_path, log=None, command: str | None = None) -> "RunLock":
        log = log or (lambda s: warnings.warn(s, stacklevel=3))
        lock = cls._acquire_path(results_path, log, command)
        try:
            lock.hold_file(results_path)
        except BaseException:
            lock.release()
            raise
        return lock

    def hold_file(self, results_path) -> None:
        """Write-lock the inode of the file now at ``results_path`` (no-op when there is none, or when it
        is one this lock holds already); :class:`ResultsLockedError` when another run holds it."""
        try:
            st = os.stat(results_path)
        except OSError:
            return
        for fd in self._file_fds:
            held = os.fstat(fd)
            if (held.st_dev, held.st_ino) == (st.st_dev, st.st_ino):
                return
        new_fd = _lock_inode(Path(results_path))
        if new_fd is not None:
            self._file_fds.append(new_fd)

    @classmethod
    def _acquire_path(cls, results_path, log, command) -> "RunLock":
        lp = lock_path(results_path)
        lp.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(10):
            fd = os.open(lp, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = _read_holder(fd)
                os.close(fd)
                raise ResultsLockedError(
                    f"{results_path} is being written by another run: {_holder_text(holder)}; lock file {lp}. "
                    f"Wait for that run to end, or {OTHER_FILE}.") from None
            except BaseException:
                os.close(fd)
                raise
            try:  # a run that releases unlinks the file: make sure we locked the one at the path
                same = os.stat(lp).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            return cls._take(results_path, lp, fd, log, command)
        raise ResultsLockedError(f"could not take the lock {lp}: it keeps being replaced by other runs")

    @classmethod
    def _take(cls, results_path, lp: Path, fd: int, log, command) -> "RunLock":
        """Write this process into the lock file it has locked; report a stale holder it replaces."""
        old = _read_holder(fd)
        info = {"pid": os.getpid(), "host": socket.gethostname(),
                "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
        if command:
            info["command"] = command[:300]
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, (json.dumps(info) + "\n").encode("utf-8"))
        os.fsync(fd)
        stale = old or None
        if stale:
            same_host = stale.get("host") == info["host"]
            state = ("no longer running" if not _pid_alive(stale.get("pid")) else "pid exists but does not hold "
                     "the lock") if same_host else "on another host; its lock was released"
            log(f"took over a stale lock on {results_path} left by {_holder_text(stale)}: {state}")
        return cls(lp, fd, info, stale)

    def release(self) -> None:
        while self._file_fds:
            os.close(self._file_fds.pop())
        if self._fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)  # unlinked while still locked: no one can lock this inode after
        except OSError:
            pass
        finally:
            os.close(self._fd)
            self._fd = None
