"""The data search path, named in ways the older tests do not name it: relative folders, and the cache by another name.

- A relative ``$STEAM_REF_DATA_DIR`` or ``data_dir`` is a folder of the working directory (as a shell reads it), not
  of the package's location: the set read is the one written there (oracle: its pose count, unlike every other's).
- The fetched files' cache stays the cache when a user names it as ``$STEAM_REF_DATA_DIR`` (with a trailing slash,
  through ``..``) or through a link as ``data_dir``: a changed file there is refused (never read as the user's own
  file), since only ``steam-ref data fetch`` writes that folder.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import scipy.io
from cli_runs import runner

from steam_ref.datasets import DATA_DIR_ENV, generate_synthetic, load_dataset, search
from steam_ref.datasets.registry import DATASETS
from steam_ref.errors import DataError

FILE = "Syn_theta_Plaza.mat"


@pytest.fixture
def alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A working directory, a fresh cache, no $STEAM_REF_DATA_DIR, no gtsam."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.delenv(DATA_DIR_ENV, raising=False)
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: None)
    (tmp_path / "cwd").mkdir()
    monkeypatch.chdir(tmp_path / "cwd")
    return tmp_path


@pytest.mark.parametrize("how", ["env", "data_dir"])
def test_a_relative_folder_is_read_from_the_working_directory(alone: Path, monkeypatch, how: str) -> None:
    mine = generate_synthetic(n_steps=7, n_landmarks=3, seed=11)
    Path("rel").mkdir()
    scipy.io.savemat(Path("rel") / FILE, mine.to_cmu_arrays())
    if how == "env":
        monkeypatch.setenv(DATA_DIR_ENV, "rel")
        data = load_dataset("paper-synthetic")
    else:
        data = load_dataset("paper-synthetic", data_dir="rel")
    assert data.n_poses == mine.n_poses == 8
    assert data.source.startswith(str(alone / "cwd" / "rel" / FILE))


@pytest.mark.parametrize("name", ["env", "env with a slash", "env through ..", "data_dir through a link"])
def test_the_cache_named_another_way_is_still_the_cache(alone: Path, shared_data: Path, monkeypatch, name: str) -> None:
    cache = search.data_cache_dir()
    cache.mkdir(parents=True)
    spoiled = bytearray((shared_data / FILE).read_bytes())
    spoiled[5000] ^= 0x01  # same size, another sha256
    (cache / FILE).write_bytes(bytes(spoiled))
    data_dir = None
    if name == "data_dir through a link":
        data_dir = alone / "link"
        data_dir.symlink_to(cache)
    else:
        monkeypatch.setenv(
            DATA_DIR_ENV, {"env": str(cache), "env with a slash": f"{cache}/"}.get(name, f"{cache}/../data")
        )
    with pytest.raises(DataError, match=r"the cached file of data set 'paper-synthetic' is not the published one"):
        load_dataset("paper-synthetic", data_dir=data_dir)


@pytest.mark.parametrize("name", ["plazza", "mydata.mat", "authors-plaza", "victoria-park", "kitti", "plaza2", "plaza"])
def test_a_search_that_finds_nothing_suggests_only_a_fetch_that_works(alone: Path, name: str) -> None:
    """The oracle of "says what to do": every ``steam-ref data fetch X`` a message suggests names a set that
    ``steam-ref data fetch`` accepts (the registry's fetchable ones), and one that makes the name loadable; the
    folder options are there for every name a file could be read under."""
    with pytest.raises(DataError) as caught:
        load_dataset(name)
    message = str(caught.value)
    suggested = re.findall(r"`steam-ref data fetch ([^`]*)`", message)
    assert all(DATASETS[x].fetchable for x in suggested if x in DATASETS) and set(suggested) <= set(DATASETS), message
    runnable = name in DATASETS and DATASETS[name].fetchable and DATASETS[name].loader is not None
    assert (name in suggested) == runnable, message  # fetching the authors' run would not make it a data set
    runs_on = name not in DATASETS or DATASETS[name].loader is not None  # else no folder would make it one
    assert ("--data-dir" in message and DATA_DIR_ENV in message) == runs_on, message
    if name == "authors-plaza":
        assert "not a data set to run on" in message and "steam-ref fidelity" in message, message
    if name == "plazza":
        assert "did you mean 'plaza'" in message, message


@pytest.mark.parametrize("command", ["run", "batch", "fit-qc"])
@pytest.mark.parametrize("name", ["plazza", "authors-plaza"])
def test_the_command_answers_a_name_that_is_no_set_and_no_file_with_the_search(
    alone: Path, capsys: pytest.CaptureFixture, command: str, name: str
) -> None:
    """Not "'plazza' is a path: say which parameters it runs with, --preset ...": with --preset it would only then
    be not found. The one line is the search's: not found, the closest name; or no data set to run on."""
    code, out, err = runner(command)(capsys, "--dataset", name)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
    assert "--preset" not in err, err
    says = "did you mean 'plaza'" if name == "plazza" else "is not a data set to run on"
    assert says in err, err


@pytest.mark.parametrize(("name", "present"), [("kitti", "KittiGps_converted.txt"), ("plaza2", "Plaza2_TD.txt")])
def test_a_folder_holding_part_of_a_sets_files_is_named_not_passed_over(
    alone: Path, monkeypatch, name: str, present: str
) -> None:
    """The user's own KittiGps_converted.txt in --data-dir, without the IMU file: reading gtsam's pair instead would
    pass over the file the user gave, in silence. The search and ``data list`` (fetch.found) both name what is
    missing there."""
    from steam_ref.datasets import fetch

    gtsam = alone / "gtsam"
    gtsam.mkdir()
    for f in DATASETS[name].files:
        (gtsam / f.local).write_text("whole set\n")
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: gtsam)
    (alone / "mine").mkdir()
    (alone / "mine" / present).write_text("the user's file\n")
    missing = [f.local for f in DATASETS[name].files if f.local != present]
    for look in (lambda: load_dataset(name, data_dir=alone / "mine"), lambda: fetch.found(name, alone / "mine")):
        with pytest.raises(DataError, match=rf"{re.escape(str(alone / 'mine'))} holds {present} but not {missing[0]}"):
            look()
