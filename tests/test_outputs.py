"""Outputs that must not be written over (issue 36, item 6): a file inside an input folder (a ROS 2
bag), and an output path that is a device, a FIFO or a symbolic link. Run as a user runs them:
the command's main function, or the command line in a subprocess."""

from __future__ import annotations

import os
import re
import stat
import subprocess
import sys

import pytest

from fuzzybrep import cli
from fuzzybrep.errors import MapFileError
from fuzzybrep.formats.files import check_outputs, write_atomic
from fuzzybrep.formats.mapfile import read_map

from test_rosbag import bag_of, room_scans

CLI = [sys.executable, "-c", "import sys; from fuzzybrep.cli import main; sys.exit(main(sys.argv[1:]))"]


def _contents(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    """A ROS 2 bag of each storage, and a map built from one."""
    d = tmp_path_factory.mktemp("bags")
    out = {s: bag_of(d / f"r2{s}", room_scans(6), ros1=False, storage=s) for s in ("sqlite3", "mcap")}
    assert cli.main(["build", str(out["mcap"]), "--out", str(d / "map.json"), "--quiet"]) == 0
    out["map"] = d / "map.json"
    return out


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_no_command_writes_over_a_file_of_its_input_bag(bags, storage, tmp_path, capsys):
    bag = bags[storage]
    before = _contents(bag)
    files = sorted(before)  # metadata.yaml and the storage file
    assert "metadata.yaml" in files and any(f.endswith((".db3", ".mcap")) for f in files)
    for name in files:
        target = str(bag / name)
        runs = {
            "build": ["build", str(bag), "--out", target, "--quiet"],
            "build (a bag file given)": ["build", str(bag / "metadata.yaml"), "--out", target, "--quiet"],
            "build --plot": ["build", str(bag), "--out", str(tmp_path / "m.json"), "--plot", target, "--quiet"],
            "drift": ["drift", str(bag), "--out", target],
            "localise": ["localise", str(bags["map"]), str(bag), "--out", target, "--quiet"],
            "grid": ["grid", str(bag), "--out", str(bag), "--name", name.rsplit(".", 1)[0], "--quiet"],
        }
        for what, argv in runs.items():
            if what == "grid" and not name.endswith(".yaml"):
                continue
            if what == "build --plot" and not name.endswith(".yaml"):
                continue  # matplotlib cannot draw a .db3 or .mcap: refused for that reason first
            assert cli.main(argv) == 2, what
            err = capsys.readouterr().err.strip()
            assert len(err.splitlines()) == 1, (what, err)
            assert re.search(rf"{name}: cannot write: it is (a file of )?the input .*; give another name$", err), err
            assert _contents(bag) == before, what
    # a link to one of the bag's files, and a hard link to it, are that file
    (tmp_path / "link.yaml").symlink_to(bag / "metadata.yaml")
    os.link(bag / files[-1], tmp_path / "hard")
    for out in ("link.yaml", "hard"):
        assert cli.main(["build", str(bag), "--out", str(tmp_path / out), "--quiet"]) == 2
        assert "input" in capsys.readouterr().err
    assert _contents(bag) == before
    # a new name in the bag's folder replaces nothing: written
    assert cli.main(["build", str(bag), "--out", str(bag / "map.json"), "--quiet"]) == 0
    (bag / "map.json").unlink()


def test_export_does_not_replace_a_bag_folder_holding_its_input(bags, tmp_path, capsys):
    bag = tmp_path / "out"
    assert cli.main(["export", str(bags["map"]), "--bag", str(bag)]) == 0
    (bag / "map.json").write_bytes(bags["map"].read_bytes())
    assert cli.main(["export", str(bag / "map.json"), "--bag", str(bag)]) == 2
    assert "the bag folder holds the input" in capsys.readouterr().err
    assert (bag / "map.json").read_bytes() == bags["map"].read_bytes()


def _special(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    return fifo


def test_a_fifo_as_output_is_refused_and_stays_a_fifo(bags, tmp_path):
    # as /dev/null would be (as root, --out /dev/null replaced the system's /dev/null with a file)
    fifo = _special(tmp_path)
    runs = [["build", str(bags["mcap"]), "--out", str(fifo)],
            ["alpha-cut", str(bags["map"]), "--alpha", "0.5", "--out", str(fifo)],
            ["export", str(bags["map"]), "--geojson", str(fifo)],
            ["view", str(bags["map"]), "--html", str(fifo)]]
    for argv in runs:
        run = subprocess.run([*CLI, *argv], capture_output=True, text=True, timeout=60)
        assert run.returncode == 2, (argv, run.stderr)
        assert run.stderr.strip().endswith(f"{fifo}: cannot write: it is a FIFO (named pipe), not a regular file, "
                                           f"and writing would replace it (give a file name)")
        assert len(run.stderr.strip().splitlines()) == 1
        assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    # the writer itself, whoever calls it, and a link to the FIFO
    with pytest.raises(MapFileError, match="it is a FIFO"):
        write_atomic(fifo, b"data")
    (tmp_path / "to-fifo").symlink_to(fifo)
    with pytest.raises(MapFileError, match="to-fifo: cannot write: it is a FIFO"):
        write_atomic(tmp_path / "to-fifo", b"data")
    with pytest.raises(MapFileError, match="it is a folder"):
        check_outputs(tmp_path, inputs=())
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and sorted(p.name for p in tmp_path.iterdir()) == ["fifo", "to-fifo"]


def test_devices_are_refused_before_anything_is_written(tmp_path):
    # /dev/null is only looked at (stat), never written: the check refuses it
    if not stat.S_ISCHR(os.stat("/dev/null").st_mode):
        pytest.skip("no /dev/null character device here")
    with pytest.raises(MapFileError, match="/dev/null: cannot write: it is a character device"):
        check_outputs("/dev/null", inputs=())


def test_writing_through_a_symbolic_link_replaces_its_target_and_keeps_the_link(bags, tmp_path):
    target = tmp_path / "maps" / "real.json"
    target.parent.mkdir()
    target.write_text("old")
    os.chmod(target, 0o640)
    link = tmp_path / "link.json"
    link.symlink_to(target)
    chain = tmp_path / "chain.json"
    chain.symlink_to("link.json")  # a link to a link, relative
    write_atomic(chain, b"new")
    assert link.is_symlink() and chain.is_symlink() and os.readlink(chain) == "link.json"
    assert target.read_bytes() == b"new" and stat.S_IMODE(target.stat().st_mode) == 0o640
    assert sorted(p.name for p in target.parent.iterdir()) == ["real.json"]  # no temporary file left
    # the command line: the map goes to the target, the link stays
    run = subprocess.run([*CLI, "build", str(bags["mcap"]), "--out", str(link), "--quiet"], capture_output=True,
                         text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    assert link.is_symlink() and read_map(target).crisp.area > 30
    # a dangling link: its target is created (its folder too)
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to(tmp_path / "new" / "made.json")
    write_atomic(dangling, b"made")
    assert dangling.is_symlink() and (tmp_path / "new" / "made.json").read_bytes() == b"made"
    # a loop of links: one line, nothing written
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    with pytest.raises(MapFileError, match="loop of links"):
        write_atomic(tmp_path / "a", b"x")
    assert (tmp_path / "a").is_symlink() and (tmp_path / "b").is_symlink()
