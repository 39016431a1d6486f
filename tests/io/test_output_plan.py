"""All the outputs of one command: checked before any work, written all-or-nothing (pcmm_geo._atomic)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest

from pcmm_geo._atomic import OutputPlan, current_transaction, may_overwrite, write_atomic
from pcmm_geo.errors import InvalidInputError, OutputExistsError


def _tree(folder: Path) -> dict[str, bytes | None]:
    """Every file (bytes) and folder (None) under ``folder``, hidden ones included."""
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None) for p in sorted(folder.rglob("*"))}


def test_check_refuses_before_any_work(tmp_path: Path) -> None:
    (tmp_path / "old.txt").write_bytes(b"recorded\n")
    (tmp_path / "a_file").write_bytes(b"x")
    plan = OutputPlan()
    plan.add(tmp_path / "new.txt", label="--first")
    plan.add(tmp_path / "old.txt", label="--second")
    with pytest.raises(OutputExistsError) as refused:
        plan.check()
    assert refused.value.path == str(tmp_path / "old.txt")

    allowed = OutputPlan()
    allowed.add(tmp_path / "new.txt", label="--first")
    allowed.add(tmp_path / "old.txt", label="--second", overwrite=True)
    allowed.check()  # the one existing output may be replaced: accepted
    appended = OutputPlan()
    appended.add(tmp_path / "old.txt", label="--out", append=True)
    appended.check()

    cases = {
        "same file twice": [(tmp_path / "x.txt", "--out"), (tmp_path / "sub" / ".." / "x.txt", "--table")],
        "folder under a file": [(tmp_path / "ok.txt", "--out"), (tmp_path / "a_file" / "deeper" / "t.csv", "--table")],
        "a folder as output": [(tmp_path, "--out")],
    }
    expected = {"same file twice": "the same file as --out", "folder under a file": "which is a file, not a folder",
                "a folder as output": "an existing folder"}
    for name, outputs in cases.items():
        plan = OutputPlan()
        for path, label in outputs:
            plan.add(path, label=label)
        with pytest.raises(InvalidInputError) as error:
            plan.check()
        assert expected[name] in str(error.value), name
    assert _tree(tmp_path) == {"a_file": b"x", "old.txt": b"recorded\n"}  # checking wrote nothing


def test_unwritable_folder_is_refused(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def read_only(*args: object, **kwargs: object) -> tuple[int, str]:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", read_only)  # as on a read-only mount (root ignores modes)
    plan = OutputPlan()
    plan.add(tmp_path / "new" / "out.png", label="--plot")
    with pytest.raises(InvalidInputError, match=r"writable folder.*Permission denied"):
        plan.check()
    assert not (tmp_path / "new").exists()


def test_rollback_removes_new_files_and_folders_and_restores_replaced_ones(tmp_path: Path) -> None:
    (tmp_path / "replaced.txt").write_bytes(b"old content \x00\xff\n")
    (tmp_path / "bystander.txt").write_bytes(b"not an output\n")
    before = _tree(tmp_path)
    plan = OutputPlan()
    plan.add(tmp_path / "replaced.txt", label="--plot", overwrite=True)
    plan.add(tmp_path / "new" / "deep" / "report.md", label="--report")
    plan.check()
    with pytest.raises(OSError, match="No space left"), plan.transaction():
        write_atomic(tmp_path / "replaced.txt", "new content\n")  # overwrite comes from the plan
        write_atomic(tmp_path / "new" / "deep" / "report.md", "report\n")
        assert (tmp_path / "replaced.txt").read_text() == "new content\n"
        raise OSError(28, "No space left on device")
    assert _tree(tmp_path) == before  # byte for byte, no folder, no backup or temporary left
    assert current_transaction() is None


def test_commit_keeps_everything_and_leaves_no_backup(tmp_path: Path) -> None:
    (tmp_path / "replaced.txt").write_bytes(b"old\n")
    plan = OutputPlan()
    plan.add(tmp_path / "replaced.txt", label="--plot", overwrite=True)
    plan.add(tmp_path / "sub" / "new.txt", label="--report")
    plan.check()
    with plan.transaction():
        write_atomic(tmp_path / "replaced.txt", "new\n")
        write_atomic(tmp_path / "sub" / "new.txt", "fresh\n")
    assert _tree(tmp_path) == {"replaced.txt": b"new\n", "sub": None, "sub/new.txt": b"fresh\n"}


def test_permission_is_per_output(tmp_path: Path) -> None:
    for name in ("plot.png", "report.md"):
        (tmp_path / name).write_bytes(b"before\n")
    plan = OutputPlan()
    plan.add(tmp_path / "plot.png", label="--plot", overwrite=True)
    plan.add(tmp_path / "report.md", label="--report", overwrite=False)
    with plan.transaction():
        assert may_overwrite(tmp_path / "plot.png") and not may_overwrite(tmp_path / "report.md", overwrite=True)
        write_atomic(tmp_path / "plot.png", "after\n")
        with pytest.raises(OutputExistsError):
            write_atomic(tmp_path / "report.md", "after\n", overwrite=True)  # the plan says no
    assert (tmp_path / "plot.png").read_text() == "after\n" and (tmp_path / "report.md").read_text() == "before\n"


def test_a_claimed_stream_is_kept_when_it_holds_a_record(tmp_path: Path) -> None:
    (tmp_path / "log.csv").write_bytes(b"earlier session\n")
    for rows, expect_kept in ((0, False), (3, True)):
        plan = OutputPlan()
        plan.add(tmp_path / "log.csv", label="--out", overwrite=True)
        with pytest.raises(KeyboardInterrupt), plan.transaction() as transaction:
            transaction.claim(tmp_path / "log.csv")
            with open(tmp_path / "log.csv", "x") as stream:
                stream.write("header\n" + "row\n" * rows)
            transaction.keep_on_failure(tmp_path / "log.csv", lambda n=rows: f"{n} rows" if n else None)
            raise KeyboardInterrupt
        if expect_kept:
            assert (tmp_path / "log.csv").read_text() == "header\n" + "row\n" * 3
            assert plan.notes[0] == f"kept {tmp_path / 'log.csv'}: 3 rows"
            backup = Path(plan.notes[1].rsplit(" ", 1)[1])
            assert backup.read_bytes() == b"earlier session\n"  # the replaced file is not lost either
        else:
            assert (tmp_path / "log.csv").read_bytes() == b"earlier session\n" and plan.notes == []


# --- what a killed run leaves (pcmm_geo._leftovers) -------------------------------------------------------------

def _dead_owner() -> str:
    """An owner tag of a process that has ended (its id is not reused within the test)."""
    import subprocess
    import sys

    from pcmm_geo._leftovers import _host

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return f"{child.pid}-12345-{_host()}"


def test_leftovers_of_dead_runs_are_removed_or_restored_and_others_left_alone(tmp_path: Path) -> None:
    from pcmm_geo._atomic import OutputPlan
    from pcmm_geo._leftovers import owner_tag

    dead, target = _dead_owner(), tmp_path / "out.csv"
    target.write_text("new, unfinished\n")
    (tmp_path / f".out-{dead}-k1uor0fe.tmp.csv").write_text("half")
    (tmp_path / f".out.csv.{dead}-0123abcd.replaced").write_text("the old result\n")
    alive = tmp_path / f".out-{owner_tag()}-abcdefgh.tmp.csv"  # this very process: alive
    alive.write_text("mine")
    elsewhere = tmp_path / f".out-{dead.rsplit('-', 1)[0]}-00000000-zzzzzzzz.tmp.csv"  # another host
    elsewhere.write_text("theirs")
    other_output = tmp_path / f".other-{dead}-k1uor0fe.tmp.csv"  # not this output's
    other_output.write_text("x")
    plan = OutputPlan()
    plan.add(target, label="OUT")
    notes = plan.recover()
    assert len(notes) == 2 and notes[0].startswith("removed ") and "interrupted run" in notes[1]
    assert target.read_text() == "the old result\n"
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == sorted(
        [alive.name, elsewhere.name, other_output.name])


def test_a_backup_that_is_the_file_itself_is_just_removed(tmp_path: Path) -> None:
    import os

    from pcmm_geo._leftovers import recover

    target = tmp_path / "out.csv"
    target.write_text("result\n")
    backup = tmp_path / f".out.csv.{_dead_owner()}-0123abcd.replaced"
    os.link(target, backup)  # killed between backing up and replacing
    [note] = recover(target)
    assert note.startswith("removed") and not backup.exists() and target.read_text() == "result\n"
