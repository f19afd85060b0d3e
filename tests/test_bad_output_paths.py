"""Output paths of the command: ``--save-estimates`` and ``--plot`` name a regular file, or
nothing yet in a folder that exists; anything else is refused before the run, in one line naming the
option, without opening it (a named pipe would block) and without changing a thing (a dangling link
is refused, neither removed nor given a target: writing through it would make a file the user never
named). A write that fails after the run (a full disk) names the option and the path and leaves what was
there as it was; a link to a file is written through and stays a link.

The paths are drawn by hypothesis from every kind of thing a path can end in, under every kind of
parent; what should happen is worked out from the kinds drawn, not from the file system.
"""

from __future__ import annotations

import errno
import os
import signal
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import steam_ref as sr
from steam_ref.cli import commands as cli
from steam_ref.cli.paths import check_out_folder, check_output, write_output
from steam_ref.errors import SteamError

# the last part of the path: (kind, accepted when its folder is a folder)
LEAVES = {
    "missing": True,
    "file": True,
    "folder": False,
    "fifo": False,
    "dangling-link": False,  # writing through it would make a file where it points (as root: into /etc)
    "link-to-missing-folder": False,
    "link-to-file": True,
    "link-to-fifo": False,
    "link-to-devnull": False,  # a character device
    "link-loop": False,
    "link-to-folder": False,
}
PARENTS = {"folder": True, "missing-folder": False, "file": False, "link-to-folder": True, "dangling-link": False}
NAME = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="/\0"), min_size=1, max_size=12)


class Reached(Exception):
    """The run started: every check before it passed."""


def _reached(*args, **kwargs):
    raise Reached


def snapshot(root: Path) -> dict:
    """Every entry under ``root``: its kind, a link's target, a file's bytes."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            if p.is_symlink():
                out[str(p)] = ("link", os.readlink(p))
            elif p.is_file():
                out[str(p)] = ("file", p.read_bytes(), oct(p.stat().st_mode))
            else:
                out[str(p)] = ("other", p.stat().st_mode >> 12)
    return out


def make(root: Path, parent_kind: str, leaf_kind: str, name: str, suffix: str) -> str:
    """Build a parent of ``parent_kind`` in ``root`` and a leaf of ``leaf_kind`` in it; the path."""
    elsewhere = root / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "target.npz").write_bytes(b"the user's file")
    os.mkfifo(elsewhere / "pipe")
    parent = root / "parent"
    if parent_kind in ("folder", "link-to-folder"):
        real = elsewhere / "real-folder" if parent_kind == "link-to-folder" else parent
        real.mkdir()
        if parent_kind == "link-to-folder":
            parent.symlink_to(real)
    elif parent_kind == "file":
        parent.write_bytes(b"a file, not a folder")
    elif parent_kind == "dangling-link":
        parent.symlink_to(root / "nowhere")
    leaf = parent / (name + suffix)
    if parent_kind not in ("folder", "link-to-folder"):
        return str(leaf)
    links = {
        "dangling-link": elsewhere / "made-after-the-run.npz",
        "link-to-missing-folder": root / "no-folder" / "x.npz",
        "link-to-file": elsewhere / "target.npz",
        "link-to-fifo": elsewhere / "pipe",
        "link-to-devnull": Path(os.devnull),
        "link-loop": leaf,
        "link-to-folder": elsewhere,
    }
    if leaf_kind == "file":
        leaf.write_bytes(b"the user's own file")
    elif leaf_kind == "folder":
        leaf.mkdir()
    elif leaf_kind == "fifo":
        os.mkfifo(leaf)
    elif leaf_kind in links:
        leaf.symlink_to(links[leaf_kind])
    return str(leaf)


@pytest.fixture(autouse=True)
def no_hang():
    """A check that blocks (opening a named pipe) fails the test instead of hanging it."""

    def hang(signum, frame):
        raise TimeoutError("the output check blocked")

    previous = signal.signal(signal.SIGALRM, hang)
    yield
    signal.setitimer(signal.ITIMER_REAL, 0)
    signal.signal(signal.SIGALRM, previous)


@settings(max_examples=150, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    parent_kind=st.sampled_from(sorted(PARENTS)),
    leaf_kind=st.sampled_from(sorted(LEAVES)),
    name=NAME,
    option=st.sampled_from(["--save-estimates", "--plot"]),
    right_suffix=st.booleans(),
)
def test_an_output_path_is_accepted_or_refused_before_the_run_and_nothing_changes(
    tmp_path_factory, monkeypatch, capsys, parent_kind, leaf_kind, name, option, right_suffix
) -> None:
    if name in (".", ".."):
        name = "x" + name
    monkeypatch.setattr("steam_ref.cli.run.StreamingEstimator", _reached)  # the run starts here
    root = tmp_path_factory.mktemp("out")
    suffix = {"--save-estimates": ".npz", "--plot": ".png"}[option] if right_suffix else ".txt"
    path = make(root, parent_kind, leaf_kind, name, suffix)
    before = snapshot(root)
    signal.setitimer(signal.ITIMER_REAL, 20)
    try:
        code = cli.main(["run", "--max-poses", "3", option, path])
    except Reached:
        code = None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    out, err = capsys.readouterr()
    assert snapshot(root) == before
    accepted = right_suffix and PARENTS[parent_kind] and LEAVES[leaf_kind]
    if accepted:
        assert code is None, err
    else:
        assert code == 2 and out == "" and len(err.splitlines()) == 1, err
        assert option in err and "Traceback" not in err
    if leaf_kind in ("fifo", "link-to-fifo", "link-to-devnull") and PARENTS[parent_kind] and right_suffix:
        assert "named pipe" in err or "character device" in err
    if parent_kind == "file" and right_suffix:
        assert "is a file, not a folder" in err
    if parent_kind == "missing-folder" and right_suffix:
        assert "does not exist" in err


@pytest.mark.parametrize("option", ["--save-estimates", "--save-trajectory", "--plot", "--tree-dot"])
def test_a_dangling_link_is_refused_in_one_line_naming_the_path_and_where_it_points(tmp_path, capsys, option):
    suffix = {"--save-estimates": ".npz", "--save-trajectory": ".txt", "--plot": ".png", "--tree-dot": ".dot"}[option]
    path = tmp_path / f"out{suffix}"
    path.symlink_to(tmp_path / "etc" / f"passwd{suffix}")  # as root: /etc/passwd
    (tmp_path / "etc").mkdir()
    code = cli.main(["run", "--max-poses", "3", option, str(path)])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and len(err.splitlines()) == 1, err
    assert f"{option}: {str(path)!r} is a symbolic link to {str(tmp_path / 'etc' / f'passwd{suffix}')!r}" in err
    assert "which does not exist" in err
    assert os.listdir(tmp_path / "etc") == [] and os.path.islink(path)
    with pytest.raises(SteamError, match="is a symbolic link to"):  # a link made dangling after the check
        write_output(str(path), option, lambda name: Path(name).write_bytes(b"estimates"))
    assert os.listdir(tmp_path / "etc") == []


@pytest.mark.parametrize("leaf_kind", ["missing", "file", "link-to-file"])
def test_an_accepted_path_is_written_through_and_a_link_stays_a_link(tmp_path: Path, leaf_kind: str) -> None:
    path = make(tmp_path, "folder", leaf_kind, "estimates", ".npz")
    check_output(path, ".npz", "--save-estimates")
    was_link = os.path.islink(path)
    write_output(path, "--save-estimates", lambda name: Path(name).write_bytes(b"the new estimates"))
    assert Path(path).read_bytes() == b"the new estimates"
    assert os.path.islink(path) == was_link
    assert not [p for p in tmp_path.rglob(".*") if p.is_file()], "a temporary file was left behind"


@pytest.mark.parametrize("leaf_kind", ["missing", "file", "link-to-file"])
@pytest.mark.parametrize("error", [errno.ENOSPC, errno.EIO, errno.EDQUOT])
def test_a_failed_write_names_the_option_and_the_path_and_changes_nothing(tmp_path: Path, leaf_kind, error) -> None:
    path = make(tmp_path, "folder", leaf_kind, "plot", ".png")
    before = snapshot(tmp_path)

    def full_disk(name: str) -> None:
        Path(name).write_bytes(b"half a pl")
        raise OSError(error, os.strerror(error))

    with pytest.raises(SteamError) as failure:
        write_output(path, "--plot", full_disk)
    assert "--plot" in str(failure.value) and repr(path) in str(failure.value)
    assert os.strerror(error) in str(failure.value)
    assert snapshot(tmp_path) == before


def test_a_full_disk_after_a_real_run_is_one_line_naming_the_option(tmp_path: Path, monkeypatch, capsys) -> None:
    target = tmp_path / "estimates.npz"
    target.write_bytes(b"yesterday's estimates")

    def full_disk(path: str, result, **kwargs) -> None:
        Path(path).write_bytes(b"PK\x03\x04 half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr("steam_ref.cli.run.save_estimates", full_disk)
    code = cli.main(["run", "--max-poses", "3", "--json", "--save-estimates", str(target)])
    _, err = capsys.readouterr()
    assert code == 2 and len(err.splitlines()) == 1
    assert "--save-estimates" in err and str(target) in err and "No space left on device" in err
    assert target.read_bytes() == b"yesterday's estimates"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["estimates.npz"]


@pytest.mark.parametrize(
    ("kind", "needle"),
    [("file", "is a file, not a folder"), ("fifo", "is a named pipe, not a folder"), ("loop", "loop")],
)
def test_out_folder_that_is_not_a_folder_says_what_it_is(tmp_path: Path, kind: str, needle: str) -> None:
    out = tmp_path / "results"
    if kind == "file":
        out.write_text("x")
    elif kind == "fifo":
        os.mkfifo(out)
    else:
        out.symlink_to(out)
    with pytest.raises(SteamError, match=needle):
        check_out_folder(str(out), "--out")


@pytest.mark.parametrize("name", ["runs.jsonl", "fig3.png", "fig4_trajectory.png", "results.md"])
@pytest.mark.parametrize("leaf_kind", ["fifo", "folder", "dangling-link"])
def test_a_file_reproduce_writes_in_its_out_folder_is_checked_before_the_runs(
    tmp_path: Path, monkeypatch, capsys, name: str, leaf_kind: str
) -> None:
    """``reproduce --out DIR`` writes its files in DIR after the runs (half an hour and more): a folder there failed
    the write at the end (a named pipe once hung it); each is refused first, naming it, and nothing changes."""
    monkeypatch.setattr("steam_ref.cli.reproduce.reproduce", _reached)  # the runs start here
    stem, suffix = os.path.splitext(name)
    path = make(tmp_path, "folder", leaf_kind, stem, suffix)
    before = snapshot(tmp_path)
    signal.setitimer(signal.ITIMER_REAL, 20)
    try:
        code = cli.main(["reproduce", "--quick", "--out", str(Path(path).parent)])
    except Reached:
        code = None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and len(err.splitlines()) == 1, err
    assert err.startswith(f"steam-ref: error: --out: {path!r} is ") and "Traceback" not in err, err
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize(("kind", "needle"), [("fifo", "is a named pipe, not"), ("file", "is a file, not")])
def test_conformance_build_out_that_is_not_a_folder_is_named_before_the_build(tmp_path, capsys, kind, needle) -> None:
    """``conformance build --out`` by the one folder check (it was "[Errno 17] File exists: '...'")."""
    out = tmp_path / "kit"
    if kind == "fifo":
        os.mkfifo(out)
    else:
        out.write_text("x")
    code = cli.main(["conformance", "build", "--out", str(out)])
    _, err = capsys.readouterr()
    assert code == 2 and err == f"steam-ref: error: --out: {str(out)!r} {needle} a folder\n", err


def test_conformance_build_replaces_a_named_pipe_in_its_kit_not_blocks_on_it(tmp_path: Path) -> None:
    """A kit file is written beside its place and moved over it whole: a named pipe at gp/cases.json (the build
    opened it to write, and waited for a reader forever) is replaced by the suite's file, and nothing is left behind."""
    from steam_ref.conformance.build import build_kit
    from steam_ref.conformance.kitio import read_suite

    (tmp_path / "gp").mkdir()
    os.mkfifo(tmp_path / "gp" / "cases.json")
    signal.setitimer(signal.ITIMER_REAL, 120)
    try:
        build_kit(tmp_path)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    assert read_suite(tmp_path, "gp")["suite"] == "gp"
    assert not list(tmp_path.rglob(".*")), "a temporary file was left behind"


def test_conformance_build_into_a_kit_of_another_version_is_refused_and_leaves_it(tmp_path: Path, capsys) -> None:
    """``build --out`` the folder of kit v4 rewrote its suites as v5 and kept its paper suite under the v5 index:
    the old kit lost, a mixed one in its place. Refused, every file as it was."""
    import shutil

    from steam_ref.conformance import KIT_VERSION, KITS

    old = tmp_path / "v4"
    shutil.copytree(KITS[KIT_VERSION - 1], old)
    before = snapshot(tmp_path)
    code = cli.main(["conformance", "build", "--out", str(old)])
    _, err = capsys.readouterr()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert f"{str(old)!r} holds the conformance kit v{KIT_VERSION - 1}: building v{KIT_VERSION} there" in err, err
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("command", ["run", "batch"])
def test_save_trajectory_refuses_to_replace_a_binary_file_and_replaces_a_text_one(tmp_path, capsys, command):
    """``--save-trajectory`` takes any name (TUM and KITTI files have no suffix of their own), and it replaced whatever
    was there: ``--dataset synthetic --save-trajectory Syn_theta_Plaza.mat`` wrote text over the paper's data set (the
    run read another file, so the check of the inputs passed). A file with a NUL byte in its first 4 KiB is never a
    trajectory the command wrote: refused in one line, byte for byte as it was; a text file is still replaced."""
    data = tmp_path / "Syn_theta_Plaza.mat"
    scipy.io.savemat(data, {"GT": np.arange(12.0).reshape(3, 4)})
    before = data.read_bytes()
    argv = [command, "--dataset", "synthetic", "--max-poses", "4", "--no-progress", "--save-trajectory"]
    code = cli.main([*argv, str(data)])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and len(err.splitlines()) == 1, err
    assert f"--save-trajectory: {str(data)!r} holds binary data, not a trajectory" in err
    assert data.read_bytes() == before
    old = tmp_path / "trajectory.txt"
    old.write_text("0 0 0 0 0 0 0 1\n")
    assert cli.main([*argv, str(old)]) == 0, capsys.readouterr().err
    assert [line.split()[0] for line in old.read_text().splitlines() if not line.startswith("#")] == [
        "1",
        "2",
        "3",
        "4",
    ]


@pytest.mark.parametrize("length", [232, 255])
def test_save_trajectory_to_a_long_name_is_written(tmp_path, capsys, length):
    """A name of up to 255 bytes is a name: --save-trajectory wrote one of 232 before write_tum went through
    files.replace_file too, then refused it ('write_tum: cannot write' a temporary's temporary, 259 bytes long);
    one of 255 was refused by either temporary alone. Now the temporaries keep the name's end within 255 bytes."""
    out = tmp_path / ("t" * (length - 4) + ".txt")
    argv = ["run", "--dataset", "synthetic", "--max-poses", "4", "--no-progress", "--save-trajectory", str(out)]
    assert cli.main(argv) == 0, capsys.readouterr().err
    rows = [line.split() for line in out.read_text().splitlines() if not line.startswith("#")]
    assert [row[0] for row in rows] == ["1", "2", "3", "4"] and all(len(row) == 8 for row in rows)
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]  # no temporary left


def test_write_tum_onto_a_folder_is_refused_as_a_folder_before_any_temporary(tmp_path, monkeypatch):
    """write_tum(folder) made its temporary in the folder's parent first and failed only at the replace: as root it
    said 'Is a directory', as anyone else (a parent they cannot write, such as / above /tmp) 'Permission denied', in
    a folder they never named. A folder is refused before any file is made (os.open: the parent not writable)."""
    target = tmp_path / "out"
    target.mkdir()

    def unwritable(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(os, "open", unwritable)
    with pytest.raises(SteamError, match=r"write_tum: cannot write .*out' \(Is a directory\)"):
        sr.write_tum(target, [0.0], [[0.0, 0.0, 0.0]])
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"] and not any(target.iterdir())


def test_save_trajectory_on_a_full_disk_names_the_option_and_the_file_not_a_temporary(tmp_path, capsys, monkeypatch):
    """Once write_tum went through files.replace_file itself, --save-trajectory's failure (a full disk) said
    'write_tum: cannot write' a hidden temporary ('.1234.89abcdef.traj.txt') in place of the option and the file
    the user gave; write_tum called on replace_file's own temporary now writes it in place, so the one message is
    the option's, and the file there is left as it was."""
    out = tmp_path / "traj.txt"
    out.write_text("0 0 0 0 0 0 0 1\n")

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(np, "savetxt", full)
    argv = ["run", "--dataset", "synthetic", "--max-poses", "4", "--no-progress", "--save-trajectory", str(out)]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1, err
    assert f"--save-trajectory: cannot write {str(out)!r} ({os.strerror(errno.ENOSPC)})" in err, err
    assert out.read_text() == "0 0 0 0 0 0 0 1\n" and sorted(p.name for p in tmp_path.iterdir()) == ["traj.txt"]
