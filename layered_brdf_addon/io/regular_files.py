"""Reading a file a user names: a regular file only (a FIFO or a device is refused, never waited
on), at most a bounded number of bytes, and its path as a message shows it.

The command line's readers of params, job and table files and the reader of a render's sidecar
use it; each says in its own words which input was refused.  Nothing here imports bpy.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any

from .messages import shown

MAX_INPUT_BYTES = 1 << 20  # a params, job or sidecar file: 1 MiB

_FILE_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
               (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


class FileRefused(ValueError):
    """A file that is not read: ``reason`` says why (it cannot be opened or read, it is not a
    regular file, it is larger than allowed)."""

    def __init__(self, path: str | os.PathLike, reason: str):
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{path}: {reason}")


def file_label(path: Any) -> str:
    """A file's path as the user gave it, for a message (a long one cut at the front)."""
    text = os.fspath(path) if isinstance(path, (str, os.PathLike)) else repr(shown(path))
    return text if len(text) <= 80 else "..." + text[-77:]


def read_regular_bytes(path: str | os.PathLike, limit: int | None = None, head: int | None = None) -> bytes:
    """The bytes of a regular file (at most ``head`` of them); :class:`FileRefused` for a file
    that cannot be opened or read, one that is not a regular file (a FIFO, a device, a folder:
    never waited on or read), and one over ``limit`` bytes."""
    p = Path(path)
    try:  # O_NONBLOCK: opening a FIFO does not wait for a writer
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise FileRefused(p, str(e.strerror or e)) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = next((k for test, k in _FILE_KINDS if test(mode)), "not a regular file")
            raise FileRefused(p, f"a regular file; this is {kind}")
        os.set_blocking(fd, True)
        want = head if head is not None else (limit + 1 if limit is not None else -1)
        chunks, total = [], 0
        while want < 0 or total < want:
            chunk = os.read(fd, 1 << 16 if want < 0 else min(1 << 16, want - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    except OSError as e:
        raise FileRefused(p, str(e.strerror or e)) from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    if limit is not None and head is None and len(data) > limit:
        raise FileRefused(p, f"at most {limit // (1 << 20)} MiB; this file is larger")
    return data
