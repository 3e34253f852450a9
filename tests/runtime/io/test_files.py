"""All-or-nothing file writing: atomic_write (one file) and staged_write (several files of one folder)."""

import os

import pytest

from svbrdf.runtime.errors import ImageError, SvbrdfError
from svbrdf.runtime.io.files import atomic_write, staged_write


def test_atomic_write_replaces_on_success(tmp_path):
    target = tmp_path / "a.json"
    with atomic_write(target) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".a.tmp-") and tmp.suffix == ".json"
        assert tmp.exists() and not target.exists()  # reserved, nothing in place yet
        tmp.write_text("one")
    assert target.read_text() == "one" and os.listdir(tmp_path) == ["a.json"]
    with pytest.raises(SvbrdfError, match=r"a\.json: exists \(pass force=True to overwrite\)"):
        with atomic_write(target):
            pass
    with atomic_write(target, force=True) as tmp:
        tmp.write_text("two")
    assert target.read_text() == "two" and os.listdir(tmp_path) == ["a.json"]


def test_atomic_write_error_in_the_block_leaves_the_target(tmp_path):
    target = tmp_path / "a.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError, match="boom"):
        with atomic_write(target, force=True) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert target.read_text() == "old" and os.listdir(tmp_path) == ["a.txt"]


def test_atomic_write_refuses_a_file_that_appeared_meanwhile(tmp_path):
    target = tmp_path / "a.txt"
    with pytest.raises(ImageError, match="exists"):
        with atomic_write(target, error=ImageError) as tmp:
            tmp.write_text("mine")
            target.write_text("theirs")
    assert target.read_text() == "theirs" and os.listdir(tmp_path) == ["a.txt"]


def test_atomic_write_missing_folder(tmp_path):
    with pytest.raises(SvbrdfError, match="does not exist"):
        with atomic_write(tmp_path / "no" / "a.txt"):
            pass
    assert os.listdir(tmp_path) == []


def test_staged_write_moves_every_file_or_none(tmp_path):
    out = tmp_path / "deep" / "out"
    with staged_write(out, ["a.txt", "b.txt"]) as stage:
        assert stage.parent == out and stage.name.startswith(".")
        (stage / "a.txt").write_text("a")
        (stage / "b.txt").write_text("b")
    assert sorted(os.listdir(out)) == ["a.txt", "b.txt"]

    with pytest.raises(SvbrdfError, match=r"a\.txt: exists \(and 1 more\)"):
        with staged_write(out, ["a.txt", "b.txt"]):
            pytest.fail("the block must not run")
    with pytest.raises(RuntimeError):
        with staged_write(out, ["a.txt", "b.txt"], force=True) as stage:
            (stage / "a.txt").write_text("new")
            raise RuntimeError("second file failed")
    assert (out / "a.txt").read_text() == "a" and sorted(os.listdir(out)) == ["a.txt", "b.txt"]


def test_staged_write_names_the_target_and_removes_the_folder_it_created(tmp_path):
    out = tmp_path / "new"
    with pytest.raises(ImageError) as exc:
        with staged_write(out, ["m.png"], error=ImageError) as stage:
            raise ImageError(f"{stage / 'm.png'}: write failed (disk full)")
    assert str(exc.value) == f"{out / 'm.png'}: write failed (disk full)"
    assert os.listdir(tmp_path) == []
    with pytest.raises(SvbrdfError, match="cannot write"):  # a file the block did not write
        with staged_write(out, ["m.png"]):
            pass
    assert os.listdir(tmp_path) == []


def test_staged_write_bad_names_and_folders(tmp_path):
    with pytest.raises(SvbrdfError, match="invalid file name"):
        with staged_write(tmp_path, ["a/b"]):
            pass
    (tmp_path / "file").write_text("x")
    with pytest.raises(SvbrdfError, match="not a folder"):
        with staged_write(tmp_path / "file", ["a"]):
            pass
    assert os.listdir(tmp_path) == ["file"]
