"""Writes that never leave a half-written file: write a temporary file beside the target, then rename.

The temporary is named ``.<target name>.cgbound-tmp-<pid>-<random><suffix>`` in the target's
directory, so a user who finds one after a crash knows what it was for; the next write to the same
target removes the ones whose writing process is gone. Replacing keeps the target's permission bits
(a 0600 file stays 0600; a new file gets the umask's default). A symlink is written through: the
link stays and the file it points to is replaced, atomically, in that file's directory.

Hard links: replacing by rename gives the path a new inode, so other hard links to the old file keep
the old contents (the link is split). Atomic replacement wins over writing in place, which would
destroy the old data if the write failed half way.
"""
import errno
import os
import secrets

TMP_MARK = ".cgbound-tmp-"


def temporary_prefix(target):
    """The name every temporary of ``target`` starts with (in the target's directory)."""
    return "." + os.path.basename(target) + TMP_MARK


def _process_alive(pid):
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:      # exists, owned by someone else
        return True
    except OSError:
        return True
    return True


def remove_stale_temporaries(target):
    """Remove the temporaries of ``target`` left by writers that are no longer running; returns their paths."""
    directory = os.path.dirname(target) or "."
    prefix = temporary_prefix(target)
    removed = []
    try:
        names = os.listdir(directory)
    except OSError:
        return removed
    for name in names:
        if not name.startswith(prefix):
            continue
        pid_text = name[len(prefix):].split("-", 1)[0]
        if not pid_text.isdigit() or _process_alive(int(pid_text)):
            continue
        stale = os.path.join(directory, name)
        try:
            if os.path.isfile(stale) and not os.path.islink(stale):
                os.unlink(stale)
                removed.append(stale)
        except OSError:
            pass
    return removed


def resolve_target(path):
    """The file a write to ``path`` replaces: ``path`` itself, or the end of its chain of symlinks."""
    path = os.path.abspath(os.fspath(path))
    if os.path.islink(path):
        return os.path.realpath(path)
    return path


def _new_temporary(target, suffix):
    """Create an empty temporary beside ``target`` with the mode the result must have; return its path."""
    directory = os.path.dirname(target)
    try:
        mode = os.stat(target).st_mode & 0o7777
    except FileNotFoundError:
        mode = None
    for _ in range(100):
        tmp = os.path.join(directory, f"{temporary_prefix(target)}{os.getpid()}-{secrets.token_hex(4)}{suffix}")
        try:
            # 0o666 under the umask: what a plain open() of a new file gives
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        except PermissionError as exc:
            raise PermissionError(exc.errno, f"path: cannot create a file in the directory of {target!r} "
                                             f"({exc.strerror})", target) from None
        try:
            if mode is not None:
                os.fchmod(fd, mode)
        finally:
            os.close(fd)
        return tmp
    raise FileExistsError(errno.EEXIST, "could not create a unique temporary file beside", target)


def _fsync_path(path, directory=False):
    try:
        fd = os.open(path, os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write(path, write, suffix=""):
    """Call ``write(tmp_path)`` and move the result onto ``path`` only if it succeeded; returns ``path``.

    ``path`` keeps its permission bits; a symlink keeps pointing at the (replaced) file. See the
    module docstring for temporaries and hard links.
    """
    if isinstance(path, bool) or not isinstance(path, (str, bytes, os.PathLike)):
        raise TypeError(f"path: expected a file name (str or os.PathLike), got {path!r}")
    path = os.fspath(path)
    if isinstance(path, bytes):
        path = os.fsdecode(path)
    if not path:
        raise ValueError("path: expected a file name, got an empty string")
    target = resolve_target(path)
    if os.path.isdir(target):
        raise IsADirectoryError(errno.EISDIR, f"path: expected a file name, got the directory {path!r}", path)
    if not os.path.isdir(os.path.dirname(target)):
        raise FileNotFoundError(errno.ENOENT, f"path: the directory to write {path!r} in does not exist", path)
    remove_stale_temporaries(target)
    tmp = _new_temporary(target, suffix or os.path.splitext(target)[1])
    try:
        write(tmp)
        _fsync_path(tmp)
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    _fsync_path(os.path.dirname(target), directory=True)
    return path
