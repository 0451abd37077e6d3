"""A warm spare of the dashboard (and of the recorder): a second copy, imported and built, serves once the first dies.

The dashboard takes seconds to start on a busy laptop (its imports, the app); a crash must not cost that. The
supervisor runs two copies with the same ``--standby-lock FILE``: whichever holds the file's lock serves, the other
waits in ``flock`` with everything imported and the app built. The kernel drops a dead process's lock at once (on
SIGKILL too), so the spare binds the port and serves, and the supervisor starts a new spare in place of the dead one.
"""

from __future__ import annotations

import fcntl
import logging
import os
from pathlib import Path

log = logging.getLogger(__name__)


def wait_to_serve(lock_file: Path) -> bool:
    """Blocks until this process holds ``lock_file``'s lock (kept for the process's life: the descriptor stays open);
    True when it had to wait, i.e. it takes over from a process that died."""
    lock_file.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(lock_file, os.O_RDWR | os.O_CREAT, 0o600)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        log.info("another copy serves already; this one waits as its spare (%s)", lock_file.name)
        fcntl.flock(fd, fcntl.LOCK_EX)
        log.warning("the serving copy is gone: this spare takes over (%s)", lock_file.name)
        return True
    return False
