"""Transactions over every output of a run: all files appear together, or none does.

A command runs inside :func:`transaction`. Every writer (assets, EXR/PNG images,
exports, text) asks :func:`atomic_path` for a path to write; inside a transaction
that is a temporary file *in the target's own folder*, named
``.<name>.shbake-<pid>-<n>.tmp<suffix>``, and folders the run needs are created
and recorded. Only when the command has finished without error are the
temporaries renamed onto their targets (``os.replace``: same folder, no copy, no
space needed). On any error or signal every temporary is removed and every
folder the run created is removed again, so each old output stays
byte-identical and no new file is left.

A run killed with ``kill -9`` cannot clean up; its temporaries carry its process
id, and the next run that writes the same target removes those whose process
no longer exists (never a live process's).

A Dask worker bakes inside :func:`collected`: its outputs are staged in a scratch
folder of its own and returned as bytes, and the client writes them in its
transaction, so nothing a worker does can appear beside a target after the client
has gone (``docs/SCENES.md``, Dask).

Outside a transaction (library use), :func:`atomic_path` is a transaction of
one file. Batches (``probe-fit`` without ``--set``) write one file per probe,
each atomic on its own (documented in ``docs/FORMAT.md`` §1).
"""

import ctypes
import errno
import os
import re
import shutil
import stat
import threading
from contextlib import contextmanager

from shbake import signals
from shbake.errors import OutputError

TAG = ".shbake-"
"""Marks shbake's temporaries: ``.<name>.shbake-<pid>-<n>.tmp<suffix>``."""

_here = threading.local()
"""Each thread's running transaction (``_here.active``): a Dask worker runs tasks in threads."""
_shared_listings: dict | None = None
"""The folder listings that the transactions begun inside :func:`listed_once` share."""
_open: list = []
_lock = threading.RLock()
_counter = 0


_TEMP_TAIL = re.compile(rf"{re.escape(TAG)}(\d+)-(\d+)\.tmp")
"""What follows a target's name in the name of its temporary (:data:`TAG`)."""


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (another user's counts as alive)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def temporaries_by_target(folder: str) -> dict[str, list[tuple[str, int]]]:
    """The shbake temporaries in ``folder`` (one listing), by the name of the target each
    stands for: ``{target name: [(temporary name, pid), ...]}``. A name that reads as the
    temporary of more than one target (a target named like a temporary) is listed under
    each. ``{}`` where the folder cannot be listed."""
    try:
        names = os.listdir(folder)
    except OSError:
        return {}
    found: dict[str, list[tuple[str, int]]] = {}
    for name in names:
        at = name.find(TAG, 1) if name.startswith(".") else -1
        while at > 0:
            m = _TEMP_TAIL.match(name, at)
            if m:
                found.setdefault(name[1:at], []).append((name, int(m.group(1))))
            at = name.find(TAG, at + 1)
    return found


def remove_stale(path: str, listings: dict | None = None) -> list[str]:
    """Remove temporaries of ``path`` left by processes that no longer exist (never this
    process's or a live one's); return their names. ``listings`` keeps each folder's
    :func:`temporaries_by_target` between calls (a transaction lists each target folder
    once, not once per staged file); without it the folder is listed now."""
    folder, base = os.path.split(os.path.abspath(path))
    with _lock:
        if listings is None or folder not in listings:
            listing = temporaries_by_target(folder)
            if listings is not None:
                listings[folder] = listing
        else:
            listing = listings[folder]
        candidates = listing.pop(base, [])
    removed, kept = [], []
    for name, pid in candidates:
        if pid == os.getpid() or pid_alive(pid):
            kept.append((name, pid))
            continue
        stale = os.path.join(folder, name)
        try:
            if os.path.isdir(stale) and not os.path.islink(stale):
                shutil.rmtree(stale)  # a staged folder (Transaction.stage_folder)
            else:
                os.remove(stale)
            removed.append(name)
        except OSError:
            kept.append((name, pid))
    if kept:
        with _lock:
            listing.setdefault(base, []).extend(kept)
    return removed


RENAME_EXCHANGE = 2
"""``renameat2`` flag (linux/fs.h): swap two paths atomically."""


def exchange(a: str, b: str) -> bool:
    """Swap the paths ``a`` and ``b`` in one step (Linux ``renameat2(RENAME_EXCHANGE)``);
    ``False`` where the system or file system cannot (nothing moved)."""
    libc = ctypes.CDLL(None, use_errno=True)
    renameat2 = getattr(libc, "renameat2", None)
    if renameat2 is None:
        return False
    at_cwd = -100  # AT_FDCWD
    if renameat2(at_cwd, os.fsencode(a), at_cwd, os.fsencode(b), RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), b)


def _read_only_fs(folder: str) -> bool:
    try:
        return bool(os.statvfs(folder).f_flag & os.ST_RDONLY)
    except OSError:
        return False


def check_output_path(path, option: str = "-o/--output") -> str:
    """Refuse an output path that cannot be written, before any work; return its folder.

    Refused: an empty path, a folder, a special file (FIFO, device, socket: the
    temporary would replace it), a parent that is missing or not a folder, a read-only
    file system or an unwritable folder.
    """
    if path is None or str(path).strip() == "":
        raise OutputError(f"{option}: empty output path")
    path = os.fspath(path)
    if path.endswith(os.sep) or os.path.isdir(path):
        raise OutputError(f"{path}: is a directory ({option} must name a file)")
    try:
        mode = os.stat(path).st_mode
    except OSError:
        mode = None
    if mode is not None and not stat.S_ISREG(mode):  # replacing /dev/null would destroy it
        kind = "a FIFO" if stat.S_ISFIFO(mode) else "a device or socket"
        raise OutputError(f"{path}: is {kind}, not a regular file ({option} must name a file)")
    folder = os.path.dirname(os.path.abspath(path))
    check_output_dir(folder, option, missing_ok=False, shown=path)
    from shbake import resources

    resources.declare_output(path)
    return folder


def check_output_dir(folder, option: str, missing_ok: bool = True, shown=None) -> str:
    """Refuse an output folder that cannot be written (or created, with ``missing_ok``)."""
    if folder is None or str(folder).strip() == "":
        raise OutputError(f"{option}: empty folder path")
    folder = os.path.abspath(os.fspath(folder))
    shown = shown or folder
    probe = folder
    while not os.path.exists(probe):
        if not missing_ok:
            raise OutputError(f"{shown}: folder {probe} does not exist ({option})")
        probe = os.path.dirname(probe)
    if not os.path.isdir(probe):
        raise OutputError(f"{shown}: {probe} is a file, not a folder ({option})")
    if _read_only_fs(probe):
        raise OutputError(f"{shown}: {probe} is on a read-only file system ({option})")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"{shown}: folder {probe} is not writable ({option})")
    return folder


def check_writable_dir(path: str) -> str:
    """Alias of :func:`check_output_path` (the folder of ``path``)."""
    return check_output_path(path)


def check_not_input(path) -> None:
    """Refuse an output that is one of the files this process has read (same inode,
    through links or another spelling): one look-up, whatever the number of inputs."""
    from shbake import resources

    src = resources.same_input(path)
    if src is not None:
        _refuse(path, src)


def _refuse(out, src) -> None:
    raise OutputError(
        f"{out}: is the input {src}; writing it would destroy the input (choose another output)"
    )


def _file_identity(path) -> tuple | None:
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return st.st_dev, st.st_ino


def refuse_same_file(outputs, inputs) -> None:
    """Refuse an output that is (through links or another name) one of the inputs: one
    ``stat`` per path (a run of 10 000 maps would otherwise compare 10⁸ pairs)."""
    by_identity = {}
    for src in inputs:
        ident = _file_identity(src) if src else None
        if ident is not None:
            by_identity.setdefault(ident, os.fspath(src))
    for out in outputs:
        ident = _file_identity(out) if out else None
        if ident is not None and ident in by_identity:
            _refuse(out, by_identity[ident])


def os_error_message(e: OSError, path: str | None = None) -> str:
    """One line for an OSError while writing ``path``."""
    where = path or e.filename or "output"
    text = str(e)
    if e.errno == errno.ENOSPC or "No space left" in text or "errno = 28," in text:
        return f"no space left on device writing {where}"
    if e.errno == errno.EROFS or "Read-only file system" in text:
        return f"read-only file system writing {where}"
    if e.errno == errno.EDQUOT:
        return f"disk quota exceeded writing {where}"
    if e.errno == errno.EFBIG or "errno = 27," in text or "File too large" in text:
        return f"file size limit exceeded writing {where}"
    lines = text.strip().splitlines()
    reason = e.strerror or (lines[0][:160] if lines else type(e).__name__)
    return f"cannot write {where} ({reason})"


def _create_file(path: str) -> None:
    """Create the empty file ``path`` (owner-only until commit), failing if it exists."""
    os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))


class Transaction:
    """The outputs of one run: staged temporaries, and folders created for them.

    ``staged`` and ``folders`` map each target to its temporary (in staging order);
    ``listings`` holds the temporaries found in each target folder, listed once per
    transaction (:func:`remove_stale`), so staging N files costs O(N), not O(N²)."""

    def __init__(self):
        self.staged: dict[str, str] = {}
        self.folders: dict[str, str] = {}
        self.created: list[str] = []
        self.listings: dict[str, dict[str, list[tuple[str, int]]]] = (
            {} if _shared_listings is None else _shared_listings
        )
        self.done = False

    def makedirs(self, folder: str) -> None:
        """Create ``folder`` (and missing parents), removed again if the run fails."""
        folder = os.path.abspath(folder)
        missing = []
        probe = folder
        while not os.path.exists(probe):
            missing.append(probe)
            probe = os.path.dirname(probe)
        for d in missing:
            if d in self.staged:
                raise OutputError(f"{d}: is an output file of this run; it cannot also be "
                                  "an output folder")  # fmt: skip
        for d in reversed(missing):
            try:
                os.mkdir(d)
            except FileExistsError:
                continue
            except OSError as e:
                raise OutputError(os_error_message(e, d)) from None
            with _lock:
                self.created.append(d)
        if not os.path.isdir(folder):
            raise OutputError(f"{folder}: exists and is not a folder")

    def stage(self, path: str) -> str:
        """A new temporary beside ``path``; it replaces ``path`` at :meth:`commit`."""
        check_output_path(path)
        check_not_input(path)
        path = os.path.abspath(os.fspath(path))
        suffix = os.path.splitext(path)[1]
        return self._new_temporary("staged", path, suffix, _create_file)

    def stage_folder(self, path: str) -> str:
        """A new empty folder beside the folder ``path``, for the run to write into (its
        files staged in it as any other); at :meth:`commit`, after those files, it replaces
        ``path`` whole: swapped in one step where Linux can (``renameat2``), the old folder
        and its files then removed, so ``path`` never holds a mix of two runs. The caller
        checks that an existing ``path`` may be replaced."""
        path = os.path.abspath(os.fspath(path))
        if os.path.islink(path) or (os.path.exists(path) and not os.path.isdir(path)):
            raise OutputError(f"{path}: exists and is not a folder")
        check_output_dir(os.path.dirname(path), "-o/--output", missing_ok=False, shown=path)
        return self._new_temporary("folders", path, "", lambda tmp: os.mkdir(tmp, 0o755))

    def _new_temporary(self, registry: str, path: str, suffix: str, make) -> str:
        """Name a temporary beside the absolute ``path`` (refused if this run already writes
        ``path``), register it in ``self.<registry>`` and create it with ``make(tmp)``.
        Registered before it exists: a signal between the two steps leaves nothing that
        abort does not remove (removing a temporary not yet made is a no-op)."""
        global _counter
        with _lock:
            if path in getattr(self, registry):
                raise OutputError(f"{path}: written twice by one run")
            _counter += 1
            n = _counter
        remove_stale(path, self.listings)
        folder, base = os.path.split(path)
        tmp = os.path.join(folder, f".{base}{TAG}{os.getpid()}-{n}.tmp{suffix}")
        with _lock:
            getattr(self, registry)[path] = tmp
        try:
            make(tmp)
        except OSError as e:
            with _lock:
                del getattr(self, registry)[path]
            raise OutputError(os_error_message(e, path)) from None
        return tmp

    def discard(self, tmp: str) -> None:
        """Remove one staged temporary (its writer failed)."""
        with _lock:
            self.staged = {f: t for f, t in self.staged.items() if t != tmp}
        _unlink(tmp)

    def commit(self) -> list[str]:
        """Move every temporary onto its target; return the targets. A signal that arrives
        while they move is raised when all have moved (:func:`shbake.signals.deferred`):
        an interrupted run leaves the old outputs or the new ones, never a mix."""
        with _lock:
            signals.raise_if_interrupted()
            with signals.deferred():  # a signal from here on: raised once all are moved
                return self._move_all()

    def _move_all(self) -> list[str]:
        done = []
        for final, tmp in list(self.staged.items()):
            try:
                os.chmod(tmp, 0o644)
                os.replace(tmp, final)
            except OSError as e:  # the files not yet moved stay staged, for abort
                raise OutputError(os_error_message(e, final)) from None
            del self.staged[final]
            done.append(final)
        for final, tmp in self.folders.items():
            try:
                _replace_folder(tmp, final)
            except OSError as e:
                raise OutputError(os_error_message(e, final)) from None
            done.append(final)
        self.staged, self.folders, self.created, self.done = {}, {}, [], True
        return done

    def abort(self) -> None:
        """Remove every temporary and every folder this run created (if empty)."""
        with _lock:
            for tmp in self.staged.values():
                _unlink(tmp)
            for tmp in self.folders.values():
                shutil.rmtree(tmp, ignore_errors=True)
            for d in reversed(self.created):
                try:
                    os.rmdir(d)
                except OSError:
                    pass
            self.staged, self.folders, self.created, self.done = {}, {}, [], True


def _replace_folder(tmp: str, final: str) -> None:
    """Move the staged folder ``tmp`` onto ``final`` (:meth:`Transaction.stage_folder`)."""
    if not os.path.lexists(final):
        os.rename(tmp, final)
        return
    if exchange(tmp, final):  # final is the new folder, tmp the old one
        shutil.rmtree(tmp, ignore_errors=True)
        return
    old = tmp + ".old"  # without renameat2: a moment where final is missing
    os.rename(final, old)
    os.rename(tmp, final)
    shutil.rmtree(old, ignore_errors=True)


class Collector(Transaction):
    """Outputs that this process makes but never commits: each is staged in ``folder``, a
    scratch folder of its own (not beside its target), for the caller to read back and
    hand to the process that commits them (a Dask worker's outputs, written by the
    client). Nothing is created beside the targets, target folders included, so nothing
    of a run can appear there after the committing process has gone."""

    def __init__(self, folder: str):
        super().__init__()
        self.folder = folder

    def makedirs(self, folder: str) -> None:
        """Nothing: the committing process creates the target folders."""

    def stage(self, path: str) -> str:
        """A new temporary in the scratch folder standing for ``path``."""
        global _counter
        path = os.path.abspath(os.fspath(path))
        with _lock:
            if path in self.staged:
                raise OutputError(f"{path}: written twice by one run")
            _counter += 1
            n = _counter
        tmp = os.path.join(self.folder, f"{n}.tmp{os.path.splitext(path)[1]}")
        with _lock:  # registered first, as in Transaction.stage
            self.staged[path] = tmp
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        return tmp

    def stage_folder(self, path: str) -> str:
        """Refused: a folder replaced whole is committed by the process that makes it."""
        raise OutputError(f"{path}: a folder output cannot be made by a worker")

    def adopt(self, path: str, data: bytes) -> None:
        """Stage ``data`` as the output ``path`` of an earlier step of the run, made in
        another process (read through :func:`staged`, as one made here)."""
        with open(self.stage(path), "wb") as f:
            f.write(data)

    def read(self, path: str) -> bytes:
        """The bytes staged for ``path`` (inside the :func:`collected` block)."""
        target = os.path.abspath(os.fspath(path))
        with _lock:
            tmp = self.staged.get(target)
        if tmp is None:
            raise OutputError(f"{path}: not written by this run")
        with open(tmp, "rb") as f:
            return f.read()


@contextmanager
def collected():
    """Run a block whose outputs are collected, not committed (:class:`Collector`): every
    transaction and :func:`detached` block inside joins it; yields the collector. Its
    scratch folder (in the system's temporary folder) is removed when the block ends."""
    import tempfile

    saved = active()
    with tempfile.TemporaryDirectory(prefix="shbake-collect-") as folder:
        t = Collector(folder)
        _here.active = t
        try:
            with _tracked(t):
                yield t
        finally:
            _here.active = saved


def _unlink(p: str) -> None:
    try:
        os.remove(p)
    except OSError:
        pass


def staged(path: str) -> str | None:
    """The temporary holding ``path`` if the running transaction has written it (so a step
    can read an output of an earlier step of the same run), else ``None``."""
    t = active()
    if t is None:
        return None
    target = os.path.abspath(os.fspath(path))
    with _lock:
        return t.staged.get(target)


def active() -> Transaction | None:
    """The transaction of the running command (in this thread), if any."""
    return getattr(_here, "active", None)


def abort_active() -> None:
    """Abort every open transaction of this process (the signal watcher calls this,
    :func:`shbake.signals.on_interrupt`)."""
    with _lock:
        for t in list(_open):
            t.abort()


signals.on_interrupt(abort_active)


@contextmanager
def _tracked(t):
    with _lock:
        _open.append(t)
    try:
        yield t
    finally:
        with _lock:
            if t in _open:
                _open.remove(t)


@contextmanager
def listed_once():
    """Run a block whose transactions (each output of a batch committed on its own,
    :func:`detached`) share their folder listings: each target folder is listed once for
    the block, not once per output (a scene bake's task of many assets in one folder). A
    temporary that appears in a listed folder during the block, of a process that then
    dies, is left to the next run. Nested blocks join the outer one."""
    global _shared_listings
    if _shared_listings is not None:
        yield
        return
    _shared_listings = {}
    try:
        yield
    finally:
        _shared_listings = None


@contextmanager
def detached():
    """Run a block outside the command's transaction: its files are committed on their own
    (one probe of a batch), so completed ones stay when a later one fails. Inside
    :func:`collected` the block stays in the collector (nothing is committed there)."""
    saved = active()
    if isinstance(saved, Collector):
        yield
        return
    _here.active = None
    try:
        yield
    finally:
        _here.active = saved


@contextmanager
def transaction():
    """Run a block as one transaction (nested blocks join the outer one)."""
    if active() is not None:
        yield active()
        return
    t = Transaction()
    _here.active = t
    try:
        with _tracked(t):
            yield t
            t.commit()
    except BaseException:
        t.abort()
        raise
    finally:
        _here.active = None


@contextmanager
def _own_transaction():
    t = Transaction()
    try:
        with _tracked(t):
            yield t
            t.commit()
    except BaseException:
        t.abort()
        raise


@contextmanager
def atomic_path(path: str, independent: bool = False):
    """Yield a temporary path beside ``path`` (same suffix) that replaces ``path`` when the
    run's transaction commits (at once outside a transaction, or with ``independent``:
    caches). OSErrors while writing it become one-line :class:`OutputError`s
    (``no space left on device writing X``)."""
    with _own_transaction() if independent else transaction() as t:
        tmp = t.stage(path)
        try:
            yield tmp
        except OSError as e:
            t.discard(tmp)
            if isinstance(e, OutputError):
                raise
            raise OutputError(os_error_message(e, path)) from None
        except BaseException:
            t.discard(tmp)
            raise


@contextmanager
def atomic_folder(folder: str):
    """Yield a staged folder, to write files into, that replaces ``folder`` whole when the
    run's transaction commits (at the block's end outside one;
    :meth:`Transaction.stage_folder`)."""
    with transaction() as t:
        yield t.stage_folder(folder)


def makedirs(folder: str) -> None:
    """Create an output folder inside the running transaction (at once outside one)."""
    with transaction() as t:
        t.makedirs(folder)


def write_text(path: str, text: str) -> None:
    """Write a text file atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
