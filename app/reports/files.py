"""What the writers of output files share: the mode a file written in place of ``path`` gets."""

from __future__ import annotations

import os
import stat


def new_file_mode(path: str) -> int:
    """The mode the file would have got from ``open``: its own if it exists, else 0o666 less umask
    (a file written to a temporary name and renamed into place keeps what ``open`` would give)."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask
