"""`simtune report --out DIR` never loses a user's file.

Every input is checked before the folder is touched, a folder of someone else's files is refused, and a
report into its own folder replaces only the files its manifest lists.  One short run and one report of
it are made per module (about 8 s); each test works on a copy of that report.
"""

import json
import shutil
import sys
import warnings
from pathlib import Path

import pytest

from simtune.errors import SimtuneError
from simtune.reference import REFERENCE_DIR
from simtune.report import make_report
from simtune.report.builder import ReportWarning
from simtune.report.folder import MANIFEST
from simtune.runs import RunConfig, start_run
from simtune.store import RunStore

ONLY = ["command_delay", "max_velocity_joint_2", "lateral_friction_plastic"]
FIGURE4 = ("figures/figure4_command_delay.png", "figures/figure4_command_delay.svg")
USER_FILES = {
    "index.html": b"<html><body>my own page</body></html>",
    "figures/my_photo.png": b"\x89PNG not really",
    "tables/my.csv": b"a,b\n1,2\n",
}


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A finished run, and a report of it with Figure 4 of command_delay (a figure the default report lacks)."""
    root = tmp_path_factory.mktemp("report_safety")
    config = RunConfig(
        optimizer="de",
        engine="mujoco",
        tasks="cube",
        space="extended",
        data=str(REFERENCE_DIR),
        max_generations=1,
        only=ONLY,
    )
    start_run(config, root / "run", show_progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ReportWarning)
        make_report(root / "run", root / "report", show_progress=False, figure4_parameter="command_delay")
    assert all((root / "report" / f).is_file() for f in FIGURE4)
    return root


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _put(folder: Path, files: dict[str, bytes]) -> None:
    for name, content in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(content)


def _copy_report(made: Path, tmp_path: Path) -> Path:
    out = tmp_path / "report"
    shutil.copytree(made / "report", out)
    return out


def test_bad_inputs_leave_an_existing_report_as_it_was(made, tmp_path):
    out = _copy_report(made, tmp_path)
    before = _files(out)
    assert len(before) > 40
    with pytest.raises(SimtuneError, match="reference.*bogus"):
        make_report(made / "run", out, show_progress=False, reference="bogus")
    assert _files(out) == before
    # a run that never finished: no usable run, found only once the runs are read
    shutil.copytree(made / "run", tmp_path / "unfinished")
    store = RunStore(tmp_path / "unfinished")
    store.set(status="running")
    store.close()
    with pytest.warns(ReportWarning, match="unfinished"), pytest.raises(SimtuneError, match="no finished runs"):
        make_report(tmp_path / "unfinished", out, show_progress=False)
    assert _files(out) == before


def test_a_folder_of_user_files_is_refused_and_left_untouched(made, tmp_path, monkeypatch, capsys):
    from simtune.cli import main

    mine = tmp_path / "mine"
    _put(mine, USER_FILES)
    monkeypatch.setattr(sys, "argv", ["simtune", "report", str(made / "run"), "--out", str(mine), "--quiet"])
    with pytest.raises(SystemExit) as stopped:
        main()
    assert stopped.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert str(mine) in lines[0] and "index.html, figures/my_photo.png, tables/my.csv" in lines[0]
    assert _files(mine) == USER_FILES
    # an index.html of another program's is no report of simtune's either
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "index.html").write_text("old report")
    with pytest.raises(SimtuneError, match="did not write"):
        make_report(made / "run", tmp_path / "old", show_progress=False)
    assert _files(tmp_path / "old") == {"index.html": b"old report"}


def test_a_manifest_naming_files_outside_the_folder_is_not_trusted(made, tmp_path):
    out = _copy_report(made, tmp_path)
    (tmp_path / "precious.txt").write_text("keep")
    manifest = json.loads((out / MANIFEST).read_text())
    manifest["files"].append("../precious.txt")
    (out / MANIFEST).write_text(json.dumps(manifest))
    before = _files(out)
    with pytest.raises(SimtuneError, match=MANIFEST):
        make_report(made / "run", out, show_progress=False)
    assert _files(out) == before and (tmp_path / "precious.txt").read_text() == "keep"


@pytest.mark.slow  # builds a second report (about 4 s)
def test_a_report_into_its_own_folder_replaces_only_its_own_files(made, tmp_path):
    out = _copy_report(made, tmp_path)
    added = {"figures/my_photo.png": b"photo", "tables/my.csv": b"x\n", "notes.txt": b"mine"}
    _put(out, added)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ReportWarning)
        index = make_report(made / "run", out, show_progress=False)  # default Figure 4: timestep, tuned by no run
    assert index == out / "index.html" and "figure4_command_delay" not in index.read_text()
    files = _files(out)
    assert not any(f in files for f in FIGURE4)  # the earlier report's, and no longer drawn: removed
    assert {name: files[name] for name in added} == added
    listed = json.loads(files[MANIFEST])["files"]
    assert set(listed) == set(files) - set(added) - {MANIFEST}
    assert "tables/runs.csv" in listed and 'name="generator"' in index.read_text()


@pytest.mark.slow  # builds a second report (about 4 s)
def test_a_user_file_named_like_a_report_file_is_never_overwritten(made, tmp_path):
    out = _copy_report(made, tmp_path)
    manifest = json.loads((out / MANIFEST).read_text())
    manifest["files"].remove("tables/runs.csv")  # as if the user had put a runs.csv of their own there
    (out / MANIFEST).write_text(json.dumps(manifest))
    (out / "tables" / "runs.csv").write_text("my runs\n")
    before = _files(out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ReportWarning)
        with pytest.raises(SimtuneError, match=r"would overwrite files it did not write \(tables/runs.csv\)"):
            make_report(made / "run", out, show_progress=False)
    assert _files(out) == before


@pytest.mark.slow  # builds a second report (about 4 s)
def test_a_report_from_before_the_manifest_is_replaced_without_its_users_files(made, tmp_path):
    out = _copy_report(made, tmp_path)
    (out / MANIFEST).unlink(missing_ok=True)
    # an earlier simtune's page: no generator tag, recognised by its title and version line
    page = (out / "index.html").read_text()
    (out / "index.html").write_text("\n".join(line for line in page.split("\n") if 'name="generator"' not in line))
    _put(out, {"figures/my_photo.png": b"photo"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ReportWarning)
        make_report(made / "run", out, show_progress=False)
    files = _files(out)
    assert files["figures/my_photo.png"] == b"photo" and MANIFEST in files
    assert not any(f in files for f in FIGURE4)  # linked from the old index.html: the old report's
    assert "figures/my_photo.png" not in json.loads(files[MANIFEST])["files"]
