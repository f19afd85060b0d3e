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
import os
import re
import shutil
import socket
import sys
import threading
from pathlib import Path
from typing import ClassVar

import pytest
from cli_runs import runner
from requirements import REPO_ROOT

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
    server = _Mirror(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/", root
    server.shutdown()
    server.server_close()


class _Mirror(http.server.ThreadingHTTPServer):
    def handle_error(self, request, client_address):
        """A client that hangs up mid-file (a download cut at its registered size) is expected, not an error to print;
        any other failure of a request is reported as the server always does."""
        if not isinstance(sys.exc_info()[1], ConnectionError):
            super().handle_error(request, client_address)


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    asked: ClassVar[list[str]] = []  # every path asked for, its query included (the mirror serves the file without it)

    def do_GET(self):
        self.asked.append(self.path)
        super().do_GET()

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


_cli = runner()


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


# The cache is checked at every read, never trusted by a file's name; everything is checked before a download.


@pytest.fixture
def own_cache(tmp_path, monkeypatch) -> Path:
    """A fresh user cache folder, the only folder searched (no $STEAM_REF_DATA_DIR, no gtsam)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv("STEAM_REF_DATA_DIR", raising=False)
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: None)
    cache = search.data_cache_dir()
    (cache / "authors").mkdir(parents=True)
    return cache


def test_a_cached_file_under_another_sets_name_is_refused_at_use(own_cache, shared_data, capsys):
    shutil.copyfile(shared_data / "Plaza1_thrown_away_some_range.mat", own_cache / "Syn_theta_Plaza.mat")
    with pytest.raises(DataError, match=r"Syn_theta_Plaza\.mat: the cached file of data set 'paper-synthetic' is not"):
        load_dataset("paper-synthetic")
    code, out, err = _cli(capsys, "run", "--dataset", "paper-synthetic", "--json")
    assert code == 2 and out == "" and err.count("\n") == 1, (code, out, err)
    assert "681,427 B where the published file has 119,549 B" in err and "steam-ref data fetch paper-synthetic" in err
    (own_cache / "Syn_theta_Plaza.mat").write_bytes(b"7 bytes")
    code, out, _ = _cli(capsys, "data", "list")
    line = next(x for x in out.splitlines() if x.startswith("paper-synthetic "))
    assert code == 0 and re.match(r"paper-synthetic\s+7 B  NOT the published file: ", line), line  # its own size
    assert fetching.missing_needs(["data:paper-synthetic"]) == ["data:paper-synthetic"]


def test_a_cached_file_changed_after_a_read_is_refused_at_the_next(own_cache, shared_data):
    """Same size, one byte changed in place: the memoized sha256 is not reused for the changed file."""
    shutil.copyfile(shared_data / "authors" / "Syn_full_data_run.mat", own_cache / "authors" / "Syn_full_data_run.mat")
    from steam_ref.paper.fidelity import find_authors_file

    assert find_authors_file("paper-synthetic") == own_cache / "authors" / "Syn_full_data_run.mat"
    with open(own_cache / "authors" / "Syn_full_data_run.mat", "r+b") as f:
        f.seek(5000)
        byte = f.read(1)
        f.seek(5000)
        f.write(bytes([byte[0] ^ 0xFF]))
    with pytest.raises(
        DataError, match=r"cached file of data set 'authors-synthetic' is not the published one \(sha256"
    ):
        find_authors_file("paper-synthetic")


def test_a_users_own_file_under_a_published_name_is_read_but_not_as_that_set(tmp_path, shared_data):
    (tmp_path / "mine").mkdir()
    shutil.copyfile(shared_data / "Plaza1_thrown_away_some_range.mat", tmp_path / "mine" / "Syn_theta_Plaza.mat")
    data = load_dataset("paper-synthetic", data_dir=tmp_path / "mine")
    assert data.name == "Syn_theta_Plaza (not the published paper-synthetic)"
    assert "not the published paper-synthetic file: 681,427 B where the published file has 119,549 B" in data.source
    assert load_dataset("plaza", data_dir=shared_data).name == "plaza"  # the published file keeps its name


def _finishes(call, seconds: float = 20.0):
    """``call()``'s exception (or None), failing the test when it has not returned after ``seconds``."""
    outcome: list = []

    def target():
        try:
            call()
            outcome.append(None)
        except Exception as exc:  # handed to the test
            outcome.append(exc)

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    assert outcome, f"still running after {seconds} s"
    return outcome[0]


@pytest.mark.parametrize("kind", ["fifo", "dev-zero"])
def test_a_non_regular_file_in_the_cache_is_refused_before_it_is_hashed(mirror, own_cache, kind):
    url, _ = mirror
    target = own_cache / "Syn_theta_Plaza.mat"
    if kind == "fifo":
        os.mkfifo(target)
    else:
        target.symlink_to("/dev/zero")
    caught = _finishes(lambda: fetching.fetch(["paper-synthetic"], base=url))
    what = "a FIFO" if kind == "fifo" else "a device"
    assert isinstance(caught, DataError) and f"Syn_theta_Plaza.mat: not a file ({what})" in str(caught), caught


def test_fetch_checks_every_name_the_url_and_the_folder_before_a_download(mirror, own_cache, tmp_path, capsys):
    url, _ = mirror
    code, _, err = _cli(capsys, "data", "fetch", "paper-synthetic", "plazza", "--base-url", url)
    assert code == 2 and "no data set named 'plazza'" in err, err
    assert not (own_cache / "Syn_theta_Plaza.mat").exists()  # the first name was not downloaded
    for bad in ("http://[::1/", "http://127.0.0.1:99999/", "http://127.0.0.1:port/"):
        with pytest.raises(DataError, match="cannot be parsed") as caught:
            fetching.fetch(["paper-synthetic"], base=bad, cache=tmp_path / "c")
        assert "sha256" not in str(caught.value)
    with pytest.raises(DataError, match="names no host"):
        fetching.fetch(["paper-synthetic"], base="http:///Data/", cache=tmp_path / "c")
    (tmp_path / "a_file").write_text("")
    with pytest.raises(DataError, match=r"the cache folder .*a_file is not a folder") as caught:
        fetching.fetch(["paper-synthetic"], base=_unreachable_url(), cache=tmp_path / "a_file")
    with pytest.raises(DataError, match=r"the cache folder /proc/steam_ref_cache cannot be written"):
        fetching.fetch(["paper-synthetic"], base=_unreachable_url(), cache="/proc/steam_ref_cache")


def test_credentials_in_the_url_are_never_shown(mirror, own_cache, tmp_path, capsys):
    url, _ = mirror
    secret = url.replace("http://", "http://someone:s3cr3t@") + "nowhere/"
    with pytest.raises(DataError, match=r"http://\*\*\*@127\.0\.0\.1:\d+/nowhere/Syn_theta_Plaza\.mat: 404") as c:
        fetching.fetch(["paper-synthetic"], base=secret, cache=tmp_path)
    assert "s3cr3t" not in str(c.value) and "someone" not in str(c.value)
    closed = _unreachable_url().replace("http://", "http://someone:s3cr3t@")
    code, _, err = _cli(capsys, "data", "fetch", "plaza", "--base-url", closed)
    assert code == 2 and "cannot fetch" in err and "s3cr3t" not in err and "someone" not in err, err
    code, _, err = _cli(capsys, "data", "fetch", "plaza", "--base-url", "ftp://someone:s3cr3t@host/")
    assert code == 2 and "s3cr3t" not in err, err


def test_a_token_in_the_urls_query_reaches_the_mirror_and_is_never_shown(
    mirror, own_cache, tmp_path, capsys, monkeypatch
):
    """A mirror that wants a token in the query (``?token=...``): each file is asked for by its name with the
    query after it, and every message shows the token's value as ``***``, as it shows user:password."""
    url, _ = mirror
    _QuietHandler.asked.clear()
    got = fetching.fetch(["paper-synthetic"], base=url + "?token=s3cr3t&expires=99", cache=tmp_path / "c")
    assert fetching.file_digest(got["paper-synthetic"][0]) == fetching.DATASETS["paper-synthetic"].files[0].sha256
    assert _QuietHandler.asked == ["/Syn_theta_Plaza.mat?token=s3cr3t&expires=99"]
    with pytest.raises(DataError, match=r"/nowhere/Syn_theta_Plaza\.mat\?token=\*\*\*&expires=\*\*\*: 404") as c:
        fetching.fetch(["paper-synthetic"], base=url + "nowhere/?token=s3cr3t&expires=99", cache=tmp_path)
    assert "s3cr3t" not in str(c.value)
    for base in (_unreachable_url() + "?token=s3cr3t", "ftp://host/?token=s3cr3t", "http://[::1/?token=s3cr3t"):
        monkeypatch.setenv("STEAM_REF_DATA_URL", base)
        code, _, err = _cli(capsys, "data", "fetch", "plaza")
        assert code == 2 and "token=***" in err and "s3cr3t" not in err, err
    assert (
        fetching.shown_url("https://someone:pw@host/a?sig&token=s3cr3t#part") == "https://***@host/a?***&token=***#part"
    )


def test_a_download_is_cut_at_the_registrys_size(mirror, tmp_path):
    url, root = mirror
    (root / "big").mkdir(exist_ok=True)
    (root / "big" / "Syn_theta_Plaza.mat").write_bytes(bytes(20 * 1024 * 1024))  # 20 MB for a 120 KB file
    written: list[int] = []
    real_open = open

    def spy(file, mode="r", *args, **kwargs):  # the size of every download file when it is closed
        handle = real_open(file, mode, *args, **kwargs)
        if "w" in mode and "tmp" in str(file):
            close = handle.close
            handle.close = lambda: (written.append(handle.tell()), close())[1]
        return handle

    import builtins

    builtins_open = builtins.open
    builtins.open = spy
    try:
        with pytest.raises(DataError, match=r"Syn_theta_Plaza\.mat: refused, the download grew past its size"):
            fetching.fetch(["paper-synthetic"], base=url + "big/", cache=tmp_path / "c")
    finally:
        builtins.open = builtins_open
    assert [p for p in (tmp_path / "c").rglob("*") if p.is_file()] == []
    assert written and max(written) <= 119_549, written


def test_an_empty_base_url_is_refused_not_passed_over_for_the_environments(mirror, own_cache, capsys, monkeypatch):
    """``--base-url ''`` names no server: refused, where it was read as not given and the files came from
    $STEAM_REF_DATA_URL's mirror (or the authors' repository) instead."""
    url, _ = mirror
    monkeypatch.setenv(fetching.DATA_URL_ENV, url)
    code, out, err = _cli(capsys, "data", "fetch", "paper-synthetic", "--base-url", "")
    assert (
        code == 2 and out == "" and err == "steam-ref: error: the base URL '' is not an http:// or https:// address\n"
    )
    assert not (own_cache / "Syn_theta_Plaza.mat").exists()
