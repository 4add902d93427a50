"""Issue 27 item 3: an asset is read only if it is a plain, self-contained HDF5 file.

Each hostile file is built with h5py from a valid asset: external storage (the issue's
``/etc/passwd``), virtual datasets, external, soft and dangling links, filters and
chunked storage. Every reader refuses it with one line naming the link or dataset,
before any value is read: the cases whose bytes would come from a FIFO would block
forever if the reader read first (they run in a subprocess with a time limit).
"""

import ast
import os
from pathlib import Path

import h5py
import numpy as np
import pytest

from shbake.errors import FormatError
from shbake.format.asset import LINKS_MAX, read_asset, write_asset
from tests.assets_examples import example, write_map
from tests.faults import PREVIEW_OF_KIND, assert_failed, shbake, unchanged
from tests.helpers import write_merl

ROOT = Path(__file__).resolve().parents[2]
SH = "/lighting/sh"
SH_SHAPE = (16, 3)
"""``/lighting/sh`` of the example env_sh asset (lmax 3, RGB, float64)."""


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    """A map, a valid env_sh asset (the source of every hostile file) and a secret file."""
    root = tmp_path_factory.mktemp("hostile")
    m = write_map(root / "map.exr")
    write_asset(str(root / "env.h5"), example("env_sh", m))
    write_asset(str(root / "table.h5"), example("brdf_table", m))
    (root / "secret.txt").write_bytes(bytes(range(256)) * 2)
    return root


def _replace_sh(make):
    """A mutation: ``/lighting/sh`` replaced by what ``make(file, name)`` creates there."""

    def fn(f, ws):
        attrs = dict(f[SH].attrs)
        del f[SH]
        make(f, SH, ws)
        if isinstance(f.get(SH, getlink=True), h5py.HardLink):
            f[SH].attrs.update(attrs)

    return fn


def _external(target):
    return _replace_sh(lambda f, name, ws: f.create_dataset(
        name, shape=SH_SHAPE, dtype="f8", external=[(target(ws), 0, 8 * 16 * 3)]))  # fmt: skip


def _virtual(target):
    def make(f, name, ws):
        layout = h5py.VirtualLayout(shape=SH_SHAPE, dtype="f8")
        layout[:] = h5py.VirtualSource(target(ws), SH, shape=SH_SHAPE)
        f.create_virtual_dataset(name, layout)

    return _replace_sh(make)


def _link(link):
    def make(f, name, ws):
        f.copy("/irradiance/sh", "/copy")  # a soft link target inside the file
        f[name] = link(ws)

    return _replace_sh(make)


def _chunked(**options):
    return _replace_sh(lambda f, name, ws: f.create_dataset(
        name, data=np.ones(SH_SHAPE), chunks=SH_SHAPE, **options))  # fmt: skip


def _user_filter(f, ws):
    """``/lighting/sh`` through filter id 32001 (Blosc, a plugin shbake does not know)."""

    def make(f, name, ws):
        ds = f.create_dataset(name, shape=SH_SHAPE, dtype="f8", chunks=SH_SHAPE,
                              compression=32001, allow_unknown_filter=True)  # fmt: skip
        ds.id.write_direct_chunk((0, 0), np.ones(SH_SHAPE).tobytes())

    _replace_sh(make)(f, ws)


def _group_link(f, ws):
    f["/elsewhere"] = h5py.ExternalLink(str(ws / "env.h5"), "/lighting")
    del f["/lighting"]
    f["/lighting"] = h5py.SoftLink("/elsewhere")


def _undeclared_external(f, ws):
    f.create_dataset("/extra", shape=(2,), dtype="u1", external=[(str(ws / "secret.txt"), 0, 2)])


def _many_links(f, ws):
    for i in range(LINKS_MAX + 1):
        f[f"/l{i}"] = h5py.SoftLink("/lighting")


SECRET = lambda ws: str(ws / "secret.txt")  # noqa: E731
FIFO = lambda ws: str(ws / "fifo")  # noqa: E731
ASSET = lambda ws: str(ws / "env.h5")  # noqa: E731

HOSTILE = {
    # id: (mutation, message fragment)
    "external-storage": (_external(SECRET), "dataset /lighting/sh keeps its bytes in the "
                                            "external file"),
    "external-storage-relative": (_external(lambda ws: "secret.txt"), "external file"),
    "external-storage-undeclared": (_undeclared_external, "dataset /extra keeps its bytes"),
    "virtual": (_virtual(ASSET), "dataset /lighting/sh is a virtual dataset"),
    "virtual-same-file": (_virtual(lambda ws: "."), "dataset /lighting/sh is a virtual dataset"),
    "external-link": (_link(lambda ws: h5py.ExternalLink(ASSET(ws), SH)),
                      "link /lighting/sh is an external link"),
    "external-link-dangling": (_link(lambda ws: h5py.ExternalLink("/nonexistent.h5", SH)),
                               "link /lighting/sh is an external link"),
    "group-links": (_group_link, "link /elsewhere is an external link"),
    "soft-link": (_link(lambda ws: h5py.SoftLink("/copy")), "link /lighting/sh is a soft link"),
    "soft-link-dangling": (_link(lambda ws: h5py.SoftLink("/nowhere")),
                           "link /lighting/sh is a soft link"),
    "gzip": (_chunked(compression="gzip", shuffle=True), "through the filter"),
    "lzf": (_chunked(compression="lzf"), "through the filter 'lzf'"),
    "fletcher32": (_chunked(fletcher32=True), "through the filter"),
    "user-filter": (_user_filter, "(id 32001)"),
    "chunked": (_chunked(), "dataset /lighting/sh has chunked storage"),
    "many-links": (_many_links, f"more than {LINKS_MAX} links"),
}  # fmt: skip


def hostile(case: str, ws, folder) -> tuple[Path, str]:
    """The env_sh asset made hostile by ``case``; ``(path, expected message fragment)``."""
    fn, fragment = HOSTILE[case]
    path = Path(folder) / f"{case}.h5"
    path.write_bytes((ws / "env.h5").read_bytes())
    with h5py.File(path, "r+") as f:
        fn(f, ws)
    return path, fragment


class TestReader:
    """``read_asset`` refuses each hostile file with one line naming what is wrong."""

    @pytest.mark.parametrize("case", list(HOSTILE))
    def test_refused(self, case, ws, tmp_path):
        path, fragment = hostile(case, ws, tmp_path)
        with pytest.raises(FormatError) as e:
            read_asset(str(path))
        msg = str(e.value)
        assert "\n" not in msg and len(msg) < 400, msg
        assert msg.startswith(f"{path}: ") and fragment in msg, msg

    def test_h5py_reads_the_hostile_bytes(self, ws, tmp_path):
        """The cases are what they claim: h5py itself reads the secret through them."""
        secret = np.frombuffer((ws / "secret.txt").read_bytes()[:384], "<f8").reshape(SH_SHAPE)
        path, _ = hostile("external-storage", ws, tmp_path)
        with h5py.File(path, "r") as f:
            assert np.array_equal(f[SH][()], secret, equal_nan=True)
        path, _ = hostile("external-link", ws, tmp_path)
        with h5py.File(path, "r") as f, h5py.File(ws / "env.h5", "r") as g:
            assert np.array_equal(f[SH][()], g[SH][()])

    def test_compact_dataset_accepted(self, ws, tmp_path):
        """Compact storage keeps the bytes in the file (the object header): read as usual."""

        def compact(f, name, ws):
            dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
            dcpl.set_layout(h5py.h5d.COMPACT)
            space = h5py.h5s.create_simple(SH_SHAPE)
            h5py.h5d.create(f.id, name.encode(), h5py.h5t.IEEE_F64LE, space, dcpl=dcpl)
            f[name][()] = np.arange(48.0).reshape(SH_SHAPE)

        path = tmp_path / "compact.h5"
        path.write_bytes((ws / "env.h5").read_bytes())
        with h5py.File(path, "r+") as f:
            _replace_sh(compact)(f, ws)
            assert f[SH].id.get_create_plist().get_layout() == h5py.h5d.COMPACT
        assert np.array_equal(read_asset(str(path))[SH], np.arange(48.0).reshape(SH_SHAPE))

    def test_driver_environment_ignored(self, ws, monkeypatch):
        """``HDF5_DRIVER`` cannot make the reader open other files (a split driver would
        read ``<name>-m.h5`` and ``<name>-r.h5``)."""
        monkeypatch.setenv("HDF5_DRIVER", "split")
        assert read_asset(str(ws / "env.h5")).kind == "env_sh"

    @pytest.mark.parametrize("driver", ["family", "split"])
    def test_multi_file_drivers_refused(self, ws, tmp_path, driver):
        """A file written by a multi-file driver is refused, not followed to its members."""
        from shbake.format.asset import WRITE_OPTIONS, write_into

        asset = read_asset(str(ws / "env.h5"))
        name = str(tmp_path / ("x%d.h5" if driver == "family" else "x.h5"))
        options = {"memb_size": 4096} if driver == "family" else {}
        with h5py.File(name, "w", driver=driver, **options, **WRITE_OPTIONS) as f:
            write_into(f, asset)
        first = tmp_path / ("x0.h5" if driver == "family" else "x.h5-m.h5")
        with pytest.raises(FormatError, match="not a readable HDF5 asset"):
            read_asset(str(first))


class TestCommands:
    """Every command that reads assets refuses them: the issue's case and the FIFO cases."""

    @pytest.mark.parametrize("target", ["threejs", "gltf", "babylon", "unity", "filament", "webgl"])
    def test_etc_passwd_export(self, run_cli, ws, tmp_path, target):
        """The issue's case: ``external=[('/etc/passwd', 0, 216)]`` was exported as SH."""
        path = tmp_path / "passwd.h5"
        path.write_bytes((ws / "env.h5").read_bytes())
        with h5py.File(path, "r+") as f:
            attrs = dict(f[SH].attrs)
            del f[SH]
            f.create_dataset(SH, shape=(9, 3), dtype="f8", external=[("/etc/passwd", 0, 216)])
            f[SH].attrs.update(attrs | {"lmax": 2})
        out = tmp_path / ("e.gltf" if target in ("gltf", "babylon") else
                          "e_sh.txt" if target == "filament" else "e.json")  # fmt: skip
        cubes = ["--env", ws / "map.exr"] if target in ("gltf", "babylon", "filament") else []
        with unchanged(tmp_path):
            msg = assert_failed(run_cli("export", path, "--to", target, "-o", out, *cubes))
        assert "dataset /lighting/sh keeps its bytes in the external file '/etc/passwd'" in msg

    @pytest.mark.parametrize("case", ["external-storage", "virtual", "external-link",
                                      "soft-link", "lzf"])  # fmt: skip
    def test_preview(self, run_cli, ws, tmp_path, case):
        path, fragment = hostile(case, ws, tmp_path)
        with unchanged(tmp_path):
            assert_failed(run_cli(*PREVIEW_OF_KIND["env_sh"](path, tmp_path / "p.exr")),
                          fragment=fragment)  # fmt: skip

    def test_preview_table(self, run_cli, ws, tmp_path):
        path = tmp_path / "table.h5"
        path.write_bytes((ws / "table.h5").read_bytes())
        with h5py.File(path, "r+") as f:
            attrs = dict(f["/table"].attrs)
            shape, dtype = f["/table"].shape, f["/table"].dtype
            del f["/table"]
            secret = [(str(ws / "secret.txt"), 0, h5py.h5f.UNLIMITED)]
            f.create_dataset("/table", shape=shape, dtype=dtype, external=secret)
            f["/table"].attrs.update(attrs)
        with unchanged(tmp_path):
            assert_failed(run_cli("preview", ws / "env.h5", "--pass", "kautz", "--table", path,
                                  "-o", tmp_path / "p.exr", "--size", 8),
                          fragment="dataset /table keeps its bytes")  # fmt: skip

    def test_recorded_merl_not_followed(self, run_cli, ws, tmp_path):
        """A measured table records its MERL file; the reference of ``preview --pass kautz``
        read whatever file was found there (no hash, not an image). It needs ``--merl``,
        and that file must be the one the table was baked from (its ``source_sha256``)."""
        merl = tmp_path / "m.binary"
        write_merl(merl, np.full((3, 90, 90, 180), 1.0 / np.pi))
        table = tmp_path / "t.h5"
        assert run_cli("brdf-table", "merl", "--merl", merl, "--size", 4, "--samples", 16,
                       "--lmax", 2, "-o", table, "-q")[0] == 0  # fmt: skip
        (tmp_path / "baked.binary").write_bytes(merl.read_bytes())
        write_merl(merl, np.full((3, 90, 90, 180), 0.5 / np.pi))  # another file, same path
        for how in (["--pass", "kautz", "--diff"], ["--pass", "reference"]):
            with unchanged(tmp_path):
                msg = assert_failed(run_cli("preview", ws / "env.h5", "--table", table, *how,
                                            "--size", 8, "-o", tmp_path / "p.exr"))  # fmt: skip
            assert f"{table}: a measured (merl) BRDF: give its MERL file with --merl" in msg
            with unchanged(tmp_path):  # given, but not the file it was baked from
                msg = assert_failed(run_cli("preview", ws / "env.h5", "--table", table, *how,
                                            "--size", 8, "--merl", merl,
                                            "-o", tmp_path / "p.exr"))  # fmt: skip
            assert f"{merl}: its SHA-256 differs" in msg
            assert msg.endswith("not the MERL file this asset was baked from"), msg
        assert run_cli("preview", ws / "env.h5", "--table", table, "--pass", "kautz", "--diff",
                       "--size", 8, "--merl", tmp_path / "baked.binary",
                       "-o", tmp_path / "p.exr", "-q")[0] == 0  # fmt: skip
        merl.unlink()
        code, _, err = run_cli("preview", ws / "env.h5", "--table", table, "--pass", "kautz",
                               "--diff", "--size", 8, "--merl", tmp_path / "given.binary",
                               "-o", tmp_path / "p.exr")  # fmt: skip
        assert code == 1 and "given.binary" in err, err  # only the file given is opened

    def test_recorded_merl_of_an_shrm_not_followed(self, run_cli, ws, tmp_path):
        """An SHRM of a measured BRDF: its reference read the recorded MERL file too. The
        file given must be the one it was baked from (``brdf_source_sha256``); an SHRM
        written before that attribute reads the file given unchecked, as it did."""
        merl = tmp_path / "m.binary"
        write_merl(merl, np.full((3, 90, 90, 180), 1.0 / np.pi))
        shrm = tmp_path / "s.h5"
        assert run_cli("shrm", ws / "map.exr", "--brdf", "merl", "--merl", merl, "--F", 2,
                       "--P", 1, "-o", shrm, "-q")[0] == 0  # fmt: skip
        merl.unlink()
        with unchanged(tmp_path):
            msg = assert_failed(run_cli("preview", shrm, "--diff", "--size", 8,
                                        "-o", tmp_path / "p.exr"))  # fmt: skip
        assert f"{shrm}: a measured (merl) BRDF: give its MERL file with --merl" in msg
        other = tmp_path / "other.binary"
        write_merl(other, np.full((3, 90, 90, 180), 0.5 / np.pi))
        for how in (["--diff"], ["--pass", "reference"]):
            with unchanged(tmp_path):
                msg = assert_failed(run_cli("preview", shrm, *how, "--size", 8, "--merl", other,
                                            "-o", tmp_path / "p.exr"))  # fmt: skip
            assert f"{other}: its SHA-256 differs" in msg
            assert msg.endswith("not the MERL file this asset was baked from"), msg
        write_merl(tmp_path / "given.binary", np.full((3, 90, 90, 180), 1.0 / np.pi))
        assert run_cli("preview", shrm, "--diff", "--size", 8, "--merl", tmp_path / "given.binary",
                       "-o", tmp_path / "p.exr", "-q")[0] == 0  # fmt: skip
        with h5py.File(shrm, "r+") as f:  # as written before brdf_source_sha256
            del f.attrs["brdf_source_sha256"]
        assert run_cli("preview", shrm, "--diff", "--size", 8, "--merl", other,
                       "-o", tmp_path / "p.exr", "-q")[0] == 0  # fmt: skip

    @pytest.mark.parametrize("case", ["external-storage", "virtual", "external-link"])
    def test_fifo_never_opened(self, ws, tmp_path, case):
        """The bytes would come from a FIFO: reading them first would block for ever."""
        fifo = tmp_path / "fifo"
        os.mkfifo(fifo)
        make, fragment = {
            "external-storage": (_external, "keeps its bytes in the external file"),
            "virtual": (_virtual, "is a virtual dataset"),
            "external-link": (lambda t: _link(lambda ws: h5py.ExternalLink(t(ws), SH)),
                              "is an external link"),
        }[case]  # fmt: skip
        path = tmp_path / f"{case}.h5"
        path.write_bytes((ws / "env.h5").read_bytes())
        with h5py.File(path, "r+") as f:
            make(lambda ws: str(fifo))(f, ws)
        with unchanged(tmp_path):
            assert_failed(shbake("export", path, "--to", "threejs", "-o", tmp_path / "e.json",
                                 timeout=60), fragment=f"/lighting/sh {fragment}")  # fmt: skip


def test_only_the_asset_module_uses_h5py():
    """Every command reads assets through ``read_asset`` (and its checks): no other module
    of the package or the CLI imports h5py."""
    users = []
    for path in sorted([*(ROOT / "shbake").rglob("*.py"), *(ROOT / "cli").rglob("*.py")]):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) else [])  # fmt: skip
            if any(n == "h5py" or n.startswith("h5py.") for n in names):
                users.append(str(path.relative_to(ROOT)))
    assert users == ["shbake/format/asset.py"]
