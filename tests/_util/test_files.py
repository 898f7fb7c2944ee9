"""Output paths: validated before computing, written whole or not at all."""

import os

import pytest

from tether._util.files import (
    ANIMATION_KINDS,
    IMAGE_KINDS,
    OutputPathError,
    atomic_output,
    check_output_dir,
    check_output_path,
)

needs_non_root = pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0,
                                    reason="root writes into read-only folders")


def test_good_path_is_returned(tmp_path):
    assert check_output_path(tmp_path / "a.png", IMAGE_KINDS) == tmp_path / "a.png"
    assert check_output_path(str(tmp_path / "a.GIF"), ANIMATION_KINDS).name == "a.GIF"


@pytest.mark.parametrize("make, fragment", [
    (lambda d: d / "missing" / "a.png", "does not exist"),
    (lambda d: d, "is a folder"),
    (lambda d: d / "noext", "no extension"),
    (lambda d: d / "a.txt", "unknown extension '.txt'"),
    (lambda d: d / "file.png" / "a.png", "is a file"),
])
def test_bad_paths_name_the_problem(tmp_path, make, fragment):
    (tmp_path / "file.png").write_bytes(b"x")
    path = make(tmp_path)
    with pytest.raises(OutputPathError) as exc:
        check_output_path(path, IMAGE_KINDS)
    msg = str(exc.value)
    assert fragment in msg and "\n" not in msg
    assert os.path.basename(str(path)) in msg


@needs_non_root
def test_read_only_folder(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        with pytest.raises(OutputPathError, match="not writable"):
            check_output_path(ro / "a.png", IMAGE_KINDS)
        with pytest.raises(OutputPathError, match="not writable"):
            check_output_dir(ro / "sub")
    finally:
        ro.chmod(0o700)


def test_output_dir(tmp_path):
    (tmp_path / "f").write_text("x")
    assert check_output_dir(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    with pytest.raises(OutputPathError, match="is a file"):
        check_output_dir(tmp_path / "f")
    with pytest.raises(OutputPathError, match="is a file"):
        check_output_dir(tmp_path / "f" / "sub")


def test_atomic_output_renames_on_success(tmp_path):
    target = tmp_path / "a.png"
    with atomic_output(target) as tmp:
        assert tmp.suffix == ".png" and tmp.parent == tmp_path and tmp != target
        tmp.write_bytes(b"data")
    assert target.read_bytes() == b"data"
    assert os.listdir(tmp_path) == ["a.png"]


def test_atomic_output_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "a.png"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError), atomic_output(target) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("boom")
    assert target.read_bytes() == b"old"
    assert os.listdir(tmp_path) == ["a.png"]
