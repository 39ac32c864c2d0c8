"""Atomic file writes: a temp file in the target's folder, then rename; no partial files.

The lowest layer (no project imports), so planner_core and lamde_mission share one writer.

Temp files are named `.NAME.lamde-tmp-PID-RANDOM` next to the target, so a write killed in
its window (SIGKILL, power loss) leaves a file that is recognisably ours: the next write to the
same target removes those whose process is gone. A whole folder written the same way (a
sortie directory) is filled as `.NAME.lamde-pending-PID` and the folder it replaces moved to
`.NAME.lamde-old-PID` (`dir_beside`); `clean_stale_dirs` removes those of processes gone.
Overwriting an existing file keeps its mode (a 0600 file stays 0600); a new file gets what a
plain `open()` would give (0666 & ~umask).

`check_writable` answers "can this path be written?" before the work that produces it starts
(by creating and removing a probe temp file in the folder, so read-only mounts, ACLs and
permissions all count, also for root); `check_folder_writable` answers it for an output folder
(a sortie directory, a suite's OUTDIR).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import stat
import tempfile
from pathlib import Path

__all__ = ["write_text_atomic", "write_bytes_atomic", "check_writable", "check_folder_writable",
           "OutputPathError",
           "pending_path", "replace_keeping_mode", "file_in_the_way", "dir_beside",
           "clean_stale_dirs", "DIR_KINDS"]

_TMP_TAG = ".lamde-tmp-"


class OutputPathError(ValueError):
    """An output path that cannot be written; the message names the path and the problem."""


def _tmp_prefix(path: Path) -> str:
    return f".{path.name}{_TMP_TAG}{os.getpid()}-"


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's live process
        return True
    except OSError:
        return True
    return True


def clean_stale_temps(path: str | Path) -> list[Path]:
    """Remove temp files an earlier, killed write to `path` left behind; returns them.

    Only files named `.NAME.lamde-tmp-PID-*` whose process PID no longer runs are removed
    (a write in progress in another process is left alone).

    Args:
        path: the target file whose folder is searched.

    Returns:
        The temp files removed ([] when the folder cannot be listed; one that cannot be
        unlinked is skipped).
    """
    path = Path(path)
    removed: list[Path] = []
    for entry in _left_by_dead(path, re.escape(f".{path.name}{_TMP_TAG}") + r"(\d+)-[^/]*"):
        with contextlib.suppress(OSError):
            os.unlink(entry)
            removed.append(entry)
    return removed


def _left_by_dead(path: Path, pattern: str) -> list[Path]:
    """The entries beside `path` whose whole name matches `pattern` (its last group a PID)
    and whose process no longer runs; [] when the folder cannot be listed."""
    folder = path.parent if str(path.parent) else Path(".")
    pat = re.compile(pattern)
    try:
        names = os.listdir(folder)
    except OSError:
        return []
    out = []
    for name in names:
        m = pat.fullmatch(name)
        if m is not None and not _pid_alive(int(m.group(m.lastindex or 0))):
            out.append(folder / name)
    return out


#: the folders a whole-folder write keeps beside its target (`dir_beside`): "pending", the new
#: folder while it is filled; "old", the folder it replaces, between the two renames
DIR_KINDS: tuple[str, ...] = ("pending", "old")


def dir_beside(path: str | Path, kind: str) -> Path:
    """The folder `.NAME.lamde-{kind}-PID` beside `path` for this process: where a folder
    written whole is filled ("pending") before it is renamed onto `path`, or where the folder
    it replaces is moved ("old") before it is removed. `clean_stale_dirs(path)` removes it
    once its process is gone.

    Args:
        path: the target folder.
        kind: one of `DIR_KINDS`.

    Returns:
        The folder's path (not created).

    Raises:
        ValueError: `kind` is not one of `DIR_KINDS`.
    """
    if kind not in DIR_KINDS:
        raise ValueError(f"kind: must be one of {', '.join(DIR_KINDS)}, got {kind!r}")
    path = Path(path)
    return path.with_name(f".{path.name}.lamde-{kind}-{os.getpid()}")


def clean_stale_dirs(path: str | Path, kinds: tuple[str, ...] = DIR_KINDS) -> list[Path]:
    """Remove the folders `dir_beside(path, kind)` that earlier, killed writes to `path` left
    behind (SIGKILL or power loss between filling the folder and renaming it); returns them.

    Only real folders named `.NAME.lamde-{kind}-PID`, kind in `kinds`, whose process PID no
    longer runs are removed: a write in progress in another process is left alone, as is this
    process's own (its writer removes it). A dead PID that a new process has taken since keeps
    its folder until that process ends (never a live writer's folder removed).

    Args:
        path: the target folder.
        kinds: which of `DIR_KINDS` to remove.

    Returns:
        The folders removed.
    """
    path = Path(path)
    removed: list[Path] = []
    pattern = re.escape(f".{path.name}.lamde-") + "(" + "|".join(map(re.escape, kinds)) + r")-(\d+)"
    for entry in _left_by_dead(path, pattern):
        if entry.is_symlink() or not entry.is_dir():
            continue
        try:
            shutil.rmtree(entry)
        except OSError:
            continue
        removed.append(entry)
    return removed


def file_in_the_way(folder: str | Path) -> Path | None:
    """The first existing ancestor of `folder` (itself included) when it is not a folder (a
    file where a folder must be, or be made), else None.

    Args:
        folder: a folder path that may not exist yet.

    Returns:
        That path, or None when the first existing ancestor is a folder (or none exists).
    """
    probe = Path(folder)
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    return probe if probe.exists() and not probe.is_dir() else None


def check_writable(path: str | Path, *, mkdir: bool = False, what: str = "") -> Path:
    """Check that `path` can be written atomically; raise OutputPathError naming it if not.

    Refused: an existing folder as the output, a parent that is a file, a missing folder
    (created instead when `mkdir`), a folder where no file can be created (read-only folder or
    mount), an existing file that is read-only.
    Also removes stale temp files of earlier killed writes (`clean_stale_temps`).

    Args:
        path: the output file.
        mkdir: create a missing folder (with its parents) instead of refusing it.
        what: prefixes the message (e.g. "--report"); "" for none.

    Returns:
        `path` as a Path.

    Raises:
        OutputPathError: `path` is not a file name, is a folder or not a regular file, is a
            read-only file, its parent is a file, or its folder is missing (without `mkdir`),
            cannot be created or cannot be written in.
    """
    path = Path(path)
    head = f"{what}: {path}" if what else str(path)
    if not path.name or path.name in (".", ".."):
        raise OutputPathError(f"{head}: not a file name")
    if path.is_dir():
        raise OutputPathError(f"{head}: is a folder, not a file")
    folder = path.parent if str(path.parent) else Path(".")
    probe = file_in_the_way(folder)
    if probe is not None:
        raise OutputPathError(f"{head}: {probe} is a file, not a folder")
    if not folder.is_dir():
        _make_folder(folder, head, mkdir)
    if path.exists():
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):
            raise OutputPathError(f"{head}: exists and is not a regular file")
        if not st.st_mode & 0o222:
            raise OutputPathError(f"{head}: the existing file is read-only")
    _probe(path, head)
    return path


def _make_folder(folder: Path, head: str, mkdir: bool) -> None:
    """The missing output folder `folder` created (with its parents) when `mkdir`, else
    OutputPathError (prefixed `head`) saying it does not exist; one too when it cannot be
    created."""
    if not mkdir:
        raise OutputPathError(
            f"{head}: the folder {folder} does not exist (create it, or pass --mkdir)"
        )
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(
            f"{head}: cannot create the folder {folder} ({exc.strerror or exc})"
        ) from None


def _probe(path: Path, head: str) -> None:
    """OutputPathError (prefixed `head`) unless a file can be made in `path`'s folder: a temp
    file named for `path` is created and removed there (so read-only mounts, ACLs and
    permissions all count, also for root); then `clean_stale_temps(path)`."""
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=_tmp_prefix(path), dir=folder)
    except OSError as exc:
        raise OutputPathError(
            f"{head}: cannot write in the folder {folder} ({exc.strerror or exc})"
        ) from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(tmp)
    clean_stale_temps(path)


def check_folder_writable(folder: str | Path, *, mkdir: bool = False, what: str = "",
                          whole: bool = False) -> Path:
    """Check that the output folder `folder` can be written; raise OutputPathError naming it if
    not. `check_writable` for a folder of outputs, before the work that fills it.

    An existing folder must take new files (a suite's OUTDIR is filled in place); a new one,
    or any folder written `whole` (filled beside itself and renamed onto its path, as a sortie
    directory: `dir_beside`), needs its parent folder to take new entries. Refused: a file at
    `folder` or at one of its ancestors, a missing parent folder (created instead when
    `mkdir`), a folder where nothing can be created (read-only folder or mount, permissions).
    Nothing is created but the parent folder `mkdir` asks for.

    Args:
        folder: the output folder (it need not exist).
        mkdir: create a missing parent folder (with its parents) instead of refusing it.
        what: prefixes the message (e.g. "--suite"); "" for none.
        whole: the folder is written whole beside itself and renamed onto `folder` (links
            followed: the parent of the folder `folder` resolves to is the one written).

    Returns:
        `folder` as a Path.

    Raises:
        OutputPathError: `folder` is a file or under one, its parent is missing (without
            `mkdir`) or cannot be created, or the folder written in cannot take a new file.
    """
    folder = Path(folder)
    head = f"{what}: {folder}" if what else str(folder)
    probe = file_in_the_way(folder)
    if probe is not None:
        where = "" if probe == folder else f"{probe} "
        raise OutputPathError(f"{head}: {where}is a file, not a folder")
    target = folder.resolve() if whole else folder
    parent = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir() and not parent.is_dir():
        _make_folder(parent, head, mkdir)
    _probe(folder / "probe" if folder.is_dir() and not whole else target, head)
    return folder


def pending_path(path: str | Path) -> Path:
    """A temp name beside `path` for a file that another writer fills before it is renamed
    onto `path` (`replace_keeping_mode`): `.NAME.lamde-tmp-PID-pending.SUFFIX` (the suffix
    kept for writers that read the format from it). `clean_stale_temps(path)` removes it once
    its process is gone.

    Args:
        path: the target file.

    Returns:
        The temp path (not created).
    """
    path = Path(path)
    return path.with_name(f"{_tmp_prefix(path)}pending{path.suffix}")


def replace_keeping_mode(tmp: str | Path, path: str | Path) -> None:
    """Rename the finished temp file `tmp` onto `path`, giving it the permission bits of the
    file it replaces (a 0600 file stays 0600), or those a plain `open()` gives a new file.

    Args:
        tmp: the written temp file, in `path`'s folder.
        path: the target.

    Raises:
        OSError: the rename failed.
    """
    try:
        mode = stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        mode = 0o666 & ~_umask()
    os.chmod(tmp, mode)
    os.replace(tmp, path)


def write_bytes_atomic(path: str | Path, data: bytes, *, mkdir: bool = True) -> Path:
    """Write `data` to `path` so that readers see either the old file or the whole new one.

    An existing file's permission bits are kept. Stale temp files of earlier killed writes to
    the same path are removed first.

    Args:
        path: the target file.
        data: the whole new content.
        mkdir: create a missing folder (with its parents); False: a missing folder raises
            FileNotFoundError.

    Returns:
        `path` as a Path.

    Raises:
        FileNotFoundError: the folder is missing and `mkdir=False`.
        OSError: the folder cannot be written (the temp file is removed).
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if mkdir:
        folder.mkdir(parents=True, exist_ok=True)
    clean_stale_temps(path)
    fd, tmp = tempfile.mkstemp(prefix=_tmp_prefix(path), dir=folder)  # 0600 while written
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        replace_keeping_mode(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text_atomic(path: str | Path, text: str, *, mkdir: bool = True) -> Path:
    """Text version of `write_bytes_atomic` (UTF-8).

    Args:
        path: the target file.
        text: the whole new content, written as UTF-8.
        mkdir: create a missing folder; False: a missing folder raises FileNotFoundError.

    Returns:
        `path` as a Path.

    Raises:
        FileNotFoundError: the folder is missing and `mkdir=False`.
        OSError: the folder cannot be written.
    """
    return write_bytes_atomic(path, text.encode("utf-8"), mkdir=mkdir)
