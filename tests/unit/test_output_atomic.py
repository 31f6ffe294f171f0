"""atomic: a file is replaced whole or not at all, and no temporary file is left behind."""

import os

import pytest

from impactsim.output.atomic import replacing, write_bytes, write_text


def test_write_text_and_bytes_replace_the_file(tmp_path):
    path = tmp_path / "a.txt"
    write_text(path, "first\n")
    write_bytes(path, b"second\n")
    assert path.read_bytes() == b"second\n"
    assert os.listdir(tmp_path) == ["a.txt"]


def test_failure_inside_replacing_keeps_old_file_and_leaves_no_temp(tmp_path):
    path = tmp_path / "state.json"
    path.write_text("old")
    with pytest.raises(RuntimeError), replacing(path) as tmp:
        tmp.write_text("half of the new")
        raise RuntimeError("killed while writing")
    assert path.read_text() == "old"
    assert os.listdir(tmp_path) == ["state.json"]


def test_temp_file_is_hidden_in_same_directory_with_same_suffix(tmp_path):
    path = tmp_path / "frame_00000.vtu"
    with replacing(path) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".") and tmp.suffix == ".vtu"
        assert not path.exists()
        tmp.write_bytes(b"x")
    assert path.read_bytes() == b"x"


def test_new_file_has_the_permissions_of_a_plain_open(tmp_path):
    plain = tmp_path / "plain"
    plain.write_text("x")
    atomic = tmp_path / "atomic"
    write_text(atomic, "x")
    assert atomic.stat().st_mode == plain.stat().st_mode
