"""Staging (``shbake/format/atomic.py``, issue 31): a transaction lists each target folder
once, not once per staged file, and keeps every guarantee — a dead process's temporaries
of a staged target removed, a live process's and other targets' kept, abort removes all."""

import os
import re

from shbake.format import atomic
from tests.faults import dead_pid

FILES_PER_FOLDER = 40


def count_listings(monkeypatch) -> dict[str, int]:
    """Count ``os.listdir`` and ``os.scandir`` calls per folder from now on."""
    calls: dict[str, int] = {}
    for name in ("listdir", "scandir"):
        real = getattr(os, name)

        def counted(path=".", _real=real):
            key = os.path.abspath(os.fspath(path))
            calls[key] = calls.get(key, 0) + 1
            return _real(path)

        monkeypatch.setattr(os, name, counted)
    return calls


def test_each_folder_listed_once_per_transaction(tmp_path, monkeypatch):
    """Old code: one listing per staged file (40 here), quadratic in a 10k-probe bake."""
    folders = [tmp_path / "a", tmp_path / "b"]
    for folder in folders:
        folder.mkdir()
    late = folders[0] / f"f{FILES_PER_FOLDER - 1}.txt"  # staged last in its folder
    dead = late.parent / f".{late.name}.shbake-{dead_pid()}-1.tmp.txt"
    live = late.parent / f".{late.name}.shbake-{os.getppid()}-1.tmp.txt"
    unstaged = late.parent / f".other.txt.shbake-{dead_pid()}-1.tmp.txt"
    for p in (dead, live, unstaged):
        p.write_text("partial")
    calls = count_listings(monkeypatch)
    with atomic.transaction():
        for folder in folders:
            for i in range(FILES_PER_FOLDER):
                atomic.write_text(str(folder / f"f{i}.txt"), str(i))
    assert {str(f): calls.get(str(f)) for f in folders} == {str(f): 1 for f in folders}
    assert not dead.exists() and live.exists() and unstaged.exists()
    assert late.read_text() == str(FILES_PER_FOLDER - 1)


def test_abort_removes_every_temporary(tmp_path):
    (tmp_path / "f0.txt").write_text("old")
    try:
        with atomic.transaction():
            for i in range(FILES_PER_FOLDER):
                atomic.write_text(str(tmp_path / f"f{i}.txt"), "new")
            raise KeyboardInterrupt
    except KeyboardInterrupt:
        pass
    assert os.listdir(tmp_path) == ["f0.txt"]
    assert (tmp_path / "f0.txt").read_text() == "old"


def test_temporaries_by_target_match_their_names(tmp_path):
    """The one listing finds, for each target, exactly the names that read as its
    temporaries (``.<target>.shbake-<pid>-<n>.tmp<suffix>``), as a regular expression per
    target says: a target named like a temporary included."""
    names = [".a.h5.shbake-12-3.tmp.h5", ".a.h5.shbake-x-3.tmp.h5", "a.h5.shbake-1-1.tmp",
             ".b.shbake-1-2.tmp.shbake-7-8.tmp", ".c.shbake-.shbake-5-6.tmp", ".shbake-1-1.tmp",
             ".d.shbake-9-9.tmpx", "plain.h5"]  # fmt: skip
    for name in names:
        (tmp_path / name).write_text("")
    found = atomic.temporaries_by_target(str(tmp_path))
    targets = ["a.h5", "b", "b.shbake-1-2.tmp", "c.shbake-", "c", "d", "plain.h5", ""]
    for target in targets:
        pattern = re.compile(rf"^\.{re.escape(target)}\.shbake-(\d+)-(\d+)\.tmp")
        expected = sorted((n, int(m.group(1))) for n in names if (m := pattern.match(n)))
        assert sorted(found.get(target, [])) == expected, target
    assert set(found) <= set(targets)


def test_outputs_committed_on_their_own_share_listings_in_listed_once(tmp_path, monkeypatch):
    """A scene task commits each asset in a transaction of its own: inside
    ``listed_once`` the folder is listed once for all of them (was once per asset), and a
    dead process's temporary of the last one is still removed."""
    last = tmp_path / f"f{FILES_PER_FOLDER - 1}.txt"
    dead = tmp_path / f".{last.name}.shbake-{dead_pid()}-1.tmp.txt"
    dead.write_text("partial")
    calls = count_listings(monkeypatch)
    with atomic.listed_once():
        for i in range(FILES_PER_FOLDER):
            with atomic.detached():
                atomic.write_text(str(tmp_path / f"f{i}.txt"), str(i))
            assert (tmp_path / f"f{i}.txt").read_text() == str(i)  # committed at once
    assert calls.get(str(tmp_path)) == 1
    assert not dead.exists()


class TestRefuseSameFile:
    """refuse_same_file: an output that is an input (a link, another spelling) is refused
    with one line, at one ``stat`` per path (old code: a ``samefile`` per pair)."""

    def test_a_link_to_an_input_is_refused(self, tmp_path):
        import pytest

        from shbake.errors import OutputError

        src = tmp_path / "map.exr"
        src.write_bytes(b"x")
        (tmp_path / "out.h5").symlink_to(src)
        with pytest.raises(OutputError, match="is the input"):
            atomic.refuse_same_file([str(tmp_path / "new.h5"), str(tmp_path / "out.h5")],
                                    [str(src)])  # fmt: skip

    def test_one_stat_per_path(self, tmp_path, monkeypatch):
        ins, outs = [], []
        for i in range(FILES_PER_FOLDER):
            for group, name in ((ins, f"m{i}.exr"), (outs, f"a{i}.h5")):
                (tmp_path / name).write_bytes(b"x")
                group.append(str(tmp_path / name))
        calls = []
        real = os.stat

        def counted(path, *a, **k):
            calls.append(path)
            return real(path, *a, **k)

        monkeypatch.setattr(os, "stat", counted)
        atomic.refuse_same_file(outs, ins)
        assert len(calls) == 2 * FILES_PER_FOLDER
