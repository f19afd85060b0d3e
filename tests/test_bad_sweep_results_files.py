"""A sweep's results file (``paper.sweep.read_results``, what ``steam-ref consistency --resume`` reads) that cannot be
used is refused with the project's DataError naming the file, the line and what is wrong, and the command answers in
one line with exit code 2: a folder, a missing or unreadable file, JSON of another shape, and JSON Python's reader
cannot take (an integer past its digit limit, a nesting past its recursion limit), which were tracebacks."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import pytest

from steam_ref.cli.commands import main
from steam_ref.errors import DataError
from steam_ref.paper.sweep import read_results

STUDY = {"n": 1}
HEAD = json.dumps({"study": STUDY})
DEEP = "[" * 100_000 + "]" * 100_000  # valid JSON, nested past Python's recursion limit
HUGE = "1" * (sys.get_int_max_str_digits() + 1)  # valid JSON, an integer past Python's digit limit
ARGS = ["consistency", "--seeds", "1", "--steps", "2", "--landmarks", "1", "--json"]


def _file(tmp_path: Path, *lines: str) -> Path:
    path = tmp_path / "runs.jsonl"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        ((DEEP,), r", line 1: not a study line: not readable JSON \(nested deeper than the reader's recursion limit\)"),
        ((HUGE,), rf", line 1: not a study line: not readable JSON \(an integer of more than {HUGE.count('1') - 1} "),
        (("[1, 2]",), r", line 1: not a study line: \[1, 2\], not an object holding 'study'"),
        (('{"runs": 3}',), r""", line 1: not a study line: \{"runs": 3\}, not an object holding 'study'"""),
        (("null",), r", line 1: not a study line: null, not an object holding 'study'"),
        ((HEAD, DEEP, '{"item": 1, "result": 2}'), r", line 2: not a result line \('\[\[\[.*recursion limit\)$"),
        ((HEAD, f'{{"item": {HUGE}, "result": 2}}', "{}"), r", line 2: not a result line .*integer of more than"),
        ((HEAD, '{"item": 1}', '{"item": 1, "result": 2}'), r", line 2: not a result line .*holding 'item' and 'resu"),
    ],
    ids=["deep", "huge", "a list", "no study", "null", "a deep row", "a huge item", "a row without result"],
)
def test_a_file_of_json_it_cannot_use_is_refused_naming_file_line_and_what(tmp_path, lines, message) -> None:
    path = _file(tmp_path, *lines)
    with pytest.raises(DataError, match=rf"^{re.escape(str(path))}{message}"):
        read_results(path, STUDY)


def test_a_folder_a_missing_file_and_an_unreadable_one_are_refused_naming_the_file(tmp_path, monkeypatch) -> None:
    with pytest.raises(DataError, match=rf"^{re.escape(str(tmp_path))}: a folder, not a results file"):
        read_results(tmp_path, STUDY)
    with pytest.raises(
        DataError, match=rf"^{re.escape(str(tmp_path / 'none.jsonl'))}: cannot read it \(No such file or directory\)"
    ):
        read_results(tmp_path / "none.jsonl", STUDY)
    path = _file(tmp_path, HEAD)
    assert read_results(path, STUDY) == {}

    def refused(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "read_bytes", refused)  # root reads any file: the refusal is made, not arranged
    with pytest.raises(DataError, match=rf"^{re.escape(str(path))}: cannot read it \(Permission denied\)"):
        read_results(path, STUDY)


@pytest.mark.parametrize("line", [DEEP, HUGE, "[]"], ids=["deep", "huge", "a list"])
def test_the_consistency_command_answers_a_bad_study_line_in_one_line_with_exit_code_2(tmp_path, capsys, line) -> None:
    path = _file(tmp_path, line)
    assert main([*ARGS, "--resume", str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1, captured.err[:500]
    assert f"{path}, line 1: not a study line" in captured.err


def test_the_consistency_command_answers_a_bad_result_line_in_one_line_with_exit_code_2(tmp_path, capsys) -> None:
    log = tmp_path / "runs.jsonl"
    assert main([*ARGS, "--log", str(log)]) == 0
    capsys.readouterr()
    head, row = log.read_text().splitlines()
    log.write_text(f"{head}\n{DEEP}\n{row}\n")
    assert main([*ARGS, "--resume", str(log)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1, captured.err[:500]
    assert f"{log}, line 2: not a result line" in captured.err and "recursion limit" in captured.err
