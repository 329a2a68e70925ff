"""Writes that never leave a half-written file: write a temporary file beside the target, then rename."""
import os
import tempfile


def atomic_write(path, write, suffix=""):
    """Call ``write(tmp_path)`` and move the result onto ``path`` only if it succeeded."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".cgbound-", suffix=suffix or os.path.splitext(path)[1], dir=directory)
    os.close(fd)
    try:
        write(tmp)
        # mkstemp creates the file private (0600); give it the mode a plain open() would
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path
