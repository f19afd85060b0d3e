"""The paper's data by name: ``steam_ref.datasets.fetch`` and ``steam-ref data fetch / list``, offline.

Files are served by a local HTTP server on 127.0.0.1 from the folder holding the paper's files
($STEAM_REF_DATA_DIR, which conftest points at the folder beside the clone), plus a corrupt copy; no
test touches the internet. The user's cache folder is a temporary one (conftest sets XDG_CACHE_HOME).
The oracle of each hash is hashlib on the served file, and the sha256 table of data/README.md.
"""

from __future__ import annotations

import functools
import hashlib
import http.server
import re
import shutil
import socket
import threading
from pathlib import Path

import pytest
from requirements import REPO_ROOT

from steam_ref.cli import main
from steam_ref.datasets import fetch as fetching
from steam_ref.datasets import load_dataset, search
from steam_ref.errors import DataError

FETCHABLE = [n for n, s in fetching.DATASETS.items() if s.fetchable]


@pytest.fixture(scope="module")
def mirror(tmp_path_factory: pytest.TempPathFactory, shared_data: Path):
    """A local mirror of matlab/Data/ (flat, as upstream) and, under bad/, a corrupt Syn_theta_Plaza.mat."""
    root = tmp_path_factory.mktemp("mirror")
    for s in fetching.DATASETS.values():
        for f in s.files if s.fetchable else ():
            shutil.copyfile(shared_data / f.local, root / f.remote)
    (root / "bad").mkdir()
    spoiled = bytearray((shared_data / "Syn_theta_Plaza.mat").read_bytes())
    spoiled[1000] ^= 0xFF
    (root / "bad" / "Syn_theta_Plaza.mat").write_bytes(bytes(spoiled))
    handler = functools.partial(_QuietHandler, directory=str(root))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/", root
    server.shutdown()
    server.server_close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _unreachable_url() -> str:
    """A port on 127.0.0.1 that nothing listens on (bound, then closed)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"http://127.0.0.1:{port}/"


def test_the_hashes_are_those_of_the_files_and_of_data_readme(shared_data: Path):
    readme = (REPO_ROOT / "data" / "README.md").read_text()
    for s in fetching.DATASETS.values():
        for f in s.files if s.fetchable else ():
            content = (shared_data / f.local).read_bytes()
            assert hashlib.sha256(content).hexdigest() == f.sha256, f.local
            assert len(content) == f.size, f.local
            assert f.sha256 in readme, f"data/README.md does not list {f.local}'s sha256"
    assert fetching.UPSTREAM_COMMIT in fetching.DEFAULT_BASE_URL and re.fullmatch(
        r"[0-9a-f]{40}", fetching.UPSTREAM_COMMIT
    )


def test_fetch_downloads_verifies_and_the_search_path_finds_them(mirror, tmp_path, monkeypatch):
    url, _ = mirror
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv("STEAM_REF_DATA_DIR", raising=False)
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: None)
    assert fetching.locate("plaza") is None
    got = fetching.fetch(base=url)
    assert sorted(got) == sorted(FETCHABLE)
    cache = search.data_cache_dir()
    for name, paths in got.items():
        for path, f in zip(paths, fetching.DATASETS[name].files, strict=True):
            assert path == cache / f.local and fetching.file_digest(path) == f.sha256
    assert search.default_data_dirs() == [cache.resolve()]
    assert load_dataset("plaza").source.startswith(str((cache / "Plaza1_thrown_away_some_range.mat").resolve()))
    assert fetching.missing_needs(["data:plaza", "data:authors-plaza"]) == []
    before = {p: p.stat().st_mtime_ns for p in cache.rglob("*.mat")}
    fetching.fetch(["plaza"], base=_unreachable_url())  # present and verified: nothing is downloaded
    assert {p: p.stat().st_mtime_ns for p in cache.rglob("*.mat")} == before


def test_a_corrupt_file_is_refused_and_nothing_is_left(mirror, tmp_path):
    url, _ = mirror
    with pytest.raises(
        DataError, match=r"Syn_theta_Plaza\.mat: refused, its sha256 is not the expected 2939aadaf29f"
    ) as caught:
        fetching.fetch(["paper-synthetic"], base=url + "bad/", cache=tmp_path / "c")
    assert "\n" not in str(caught.value)
    assert [p for p in (tmp_path / "c").rglob("*") if p.is_file()] == []


def test_an_unreachable_host_and_a_missing_file_are_one_line(mirror, tmp_path):
    url, _ = mirror
    with pytest.raises(
        DataError, match=r"cannot fetch http://127\.0\.0\.1:\d+/Plaza1_thrown_away_some_range\.mat: Connection"
    ) as caught:
        fetching.fetch(["plaza"], base=_unreachable_url(), cache=tmp_path)
    assert "\n" not in str(caught.value)
    with pytest.raises(DataError, match=r"nowhere/Syn_theta_Plaza\.mat: 404"):
        fetching.fetch(["paper-synthetic"], base=url + "nowhere", cache=tmp_path)
    with pytest.raises(DataError, match=r"'victoria-park' is not fetched: it ships in the gtsam wheel"):
        fetching.fetch(["victoria-park"], base=url, cache=tmp_path)
    with pytest.raises(DataError, match=r"no data set named 'plazza'; the names are: paper-synthetic, plaza"):
        fetching.fetch(["plazza"], base=url, cache=tmp_path)
    with pytest.raises(DataError, match=r"base URL 'ftp://x' is not an http"):
        fetching.fetch(["plaza"], base="ftp://x", cache=tmp_path)


def _cli(capsys: pytest.CaptureFixture, *args: str) -> tuple[int, str, str]:
    """``steam-ref ARGS`` in this process (the command's own entry point): exit code, stdout, stderr."""
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_the_command_fetches_lists_and_fails_in_one_line(mirror, tmp_path, monkeypatch, capsys):
    url, _ = mirror
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv("STEAM_REF_DATA_DIR", raising=False)
    monkeypatch.setenv("STEAM_REF_DATA_URL", url)
    code, out, _ = _cli(capsys, "data", "list")
    assert code == 0 and re.search(r"^plaza\s.*absent", out, flags=re.M), out
    code, out, err = _cli(capsys, "data", "fetch", "plaza", "authors-plaza")
    assert code == 0, err
    cache = tmp_path / "xdg" / "steam_ref" / "data"
    assert (cache / "authors" / "Plaza1_full_data_run.mat").is_file()
    assert f"plaza: {cache / 'Plaza1_thrown_away_some_range.mat'} (sha256 534183903..." not in out  # 12 hex digits
    assert f"plaza: {cache / 'Plaza1_thrown_away_some_range.mat'} (sha256 5341839031c6, verified)" in out
    code, out, _ = _cli(capsys, "data", "list")
    assert re.search(rf"^plaza\s.*present\s+{re.escape(str(cache))}$", out, flags=re.M), out
    assert re.search(rf"^authors-plaza\s.*present\s+{re.escape(str(cache))}$", out, flags=re.M), out
    assert "XinyanGT/online-gpslam-code" in out and "681,427" in out
    code, _, err = _cli(capsys, "data", "fetch", "paper-synthetic", "--base-url", url + "bad/")
    assert code == 2 and err.count("\n") == 1 and "refused" in err, err
    assert not (cache / "Syn_theta_Plaza.mat").exists()
    code, _, err = _cli(capsys, "data", "fetch", "paper-synthetic", "--base-url", _unreachable_url())
    assert code == 2 and err.count("\n") == 1 and "cannot fetch" in err, err
    code, _, err = _cli(capsys, "data", "fetch", "plazza")
    assert code == 2 and "no data set named 'plazza'" in err, err


def test_a_newcomer_third_command_is_data_fetch():
    readme = (REPO_ROOT / "README.md").read_text()
    commands = re.findall(r"^    (.+)$", readme.split("## More commands")[0], flags=re.M)
    assert "steam-ref data fetch" in commands[2], commands[:3]
