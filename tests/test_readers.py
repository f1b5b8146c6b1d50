"""Scans in: CARMEN logs, the CSV scan format, bad input, consolidation of 180° scans (thesis 5.2)."""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from fuzzybrep import MapFileError, ScanFormatError, ScanValueError
from fuzzybrep.scans.carmen import read_carmen
from fuzzybrep.scans.consolidate import consolidate, consolidate_pairs
from fuzzybrep.scans.csvscans import read_csv, write_csv
from fuzzybrep.scans.report import ReadReport
from fuzzybrep.scans.read import read_scans
from fuzzybrep.scans.scan import Scan, even_bearings

from conftest import log_path


def flaser(ranges, pose=(1.0, 2.0, 0.5), t=10.0) -> str:
    r = " ".join(str(x) for x in ranges)
    x, y, th = pose
    return f"FLASER {len(ranges)} {r} {x} {y} {th} {x} {y} {th} {t} host {t}\n"


def write_log(path, lines, gz=False):
    data = "".join(lines).encode()
    if gz:
        data = gzip.compress(data)
    path.write_bytes(data)
    return path


GOOD = [
    "# a comment\n",
    "PARAM robot_frontlaser_offset 0.0 nohost 0\n",
    "ODOM 0 0 0 0 0 0 0.1 host 0.1\n",
    flaser([1.0, 2.0, 81.83, 3.0, 4.0], t=1.0),
    flaser([1.5, 2.5, 3.5, 81.83, 2.0], pose=(2.0, 2.0, 0.0), t=2.0),
]


@pytest.mark.parametrize("gz", [False, True])
def test_carmen_reads_flaser_plain_and_gzip(tmp_path, gz):
    p = write_log(tmp_path / ("a.log.gz" if gz else "a.log"), GOOD, gz)
    scans = read_scans(p)
    assert len(scans) == 2
    s = scans[0]
    assert np.allclose(s.ranges, [1.0, 2.0, 81.83, 3.0, 4.0])
    # five beams from -90° to +90° with both ends included
    assert np.allclose(np.degrees(s.bearings), [-90, -45, 0, 45, 90])
    assert np.allclose(s.pose, [1.0, 2.0, 0.5]) and s.timestamp == 1.0
    # the largest range is the "no return" sentinel by default
    assert s.max_range == 81.83
    assert s.returns.tolist() == [True, True, False, True, True]
    assert s.source.endswith(":4")


def test_carmen_explicit_max_range(tmp_path):
    p = write_log(tmp_path / "a.log", GOOD)
    s = read_carmen(p, max_range=3.2)[0]
    assert s.returns.tolist() == [True, True, False, True, False]


@pytest.mark.parametrize(
    "line, field, cls, words",
    [
        (flaser([1.0, float("nan"), 2.0]), "r_2", ScanValueError, "range 'nan' is not finite"),
        (flaser([1.0, -2.0, 2.0]), "r_2", ScanValueError, "range '-2.0' is negative"),
        (flaser([1.0, "abc", 2.0]), "r_2", ScanFormatError, "not a number"),
        ("FLASER 5 1.0 2.0 3.0\n", None, ScanFormatError, "truncated"),
        ("FLASER x 1.0\n", "n", ScanFormatError, "not an integer"),
        ("FLASER 0 1 2 0.5 1 2 0.5 10 host 10\n", "n", ScanFormatError, "beam count 0 must be positive"),
        # every field but the timestamp, in a log without host and logger timestamp: cut short, not a
        # wrong beam count
        ("FLASER 2 1.0 2.0 1 2 3 1 2 3\n", None, ScanFormatError, "truncated: 10 fields"),
        ("FLASER 2 1.0 2.0 1 2 nan 1 2 3 4 h 4\n", "theta", ScanValueError, "not finite"),
        ("FLASER 2 1.0 2.0 1 2 3 1 2 3 oops h 4\n", "timestamp", ScanFormatError, "not a number"),
        # cut after the host: before, "beam count 2 does not match the line's 12 fields", blaming the count
        ("FLASER 2 1.0 2.0 1 2 3 1 2 3 4 host\n", None, ScanFormatError,
         "truncated: 12 fields, ending at the host 'host'; a FLASER line with 2 beams has 13, the logger timestamp last"),
    ],
)
def test_carmen_bad_lines_name_file_line_and_field(tmp_path, line, field, cls, words):
    p = write_log(tmp_path / "bad.log", [GOOD[3], line, GOOD[4]])
    with pytest.raises(cls) as e:
        read_carmen(p)
    err = e.value
    assert err.line == 2 and err.field == field and words in str(err)
    assert "bad.log" in str(err) and "line 2" in str(err)


@pytest.mark.parametrize(
    "line, words",
    [
        # one range more than n says: before, that range was read as x and the pose shifted by one
        ("FLASER 2 1.0 2.0 3.0 1 2 0.5 1 2 0.5 10 host 10\n", "beam count 2 does not match the line's 14 fields"),
        # one range fewer: before, x was read as a range and the heading as odom_x
        ("FLASER 4 1.0 2.0 3.0 1 2 0.5 1 2 0.5 10 host 10\n", "beam count 4 does not match the line's 14 fields"),
        # a log without host and logger timestamp, n two short: the fields count as a long line
        ("FLASER 1 1.0 2.0 3.0 1 2 0.5 1 2 0.5 10\n", "there is the number '0.5'"),
    ],
)
def test_carmen_beam_count_that_disagrees_with_the_ranges(tmp_path, line, words):
    p = write_log(tmp_path / "bad.log", [GOOD[3], line, GOOD[4]])
    with pytest.raises(ScanFormatError, match="bad.log, line 2, field n: .*" + words):
        read_carmen(p)
    # logs without host and logger timestamp still read
    short = write_log(tmp_path / "short.log", ["FLASER 3 1.0 2.0 3.0 1 2 0.5 1 2 0.5 10\n"])
    assert read_carmen(short)[0].ranges.tolist() == [1.0, 2.0, 3.0]


def test_carmen_skip_bad_reports_how_many(tmp_path):
    p = write_log(tmp_path / "bad.log", [GOOD[3], flaser([1.0, -1.0, 2.0]), "FLASER 9 1 2\n", GOOD[4]])
    report = ReadReport()
    scans = read_carmen(p, skip_bad=True, report=report)
    assert len(scans) == 2 and report.skipped == 2 and report.scans == 2
    assert [e.line for e in report.errors] == [2, 3]
    assert "2 bad lines skipped" in report.summary()


def test_skip_bad_with_every_scan_bad_says_so(tmp_path):
    # before: "no FLASER scans in this file" and "no usable scans", though every scan was there and bad
    p = write_log(tmp_path / "bad.log", [flaser([1.0, -1.0, 2.0]), flaser([float("nan"), 1.0, 2.0])])
    with pytest.raises(ScanFormatError, match=r"bad.log: no usable FLASER scans: all 2 were skipped as bad "
                                              r"\(first: .*bad.log, line 1, field r_2: range '-1.0' is negative\)"):
        read_carmen(p, skip_bad=True)
    c = tmp_path / "bad.csv"
    c.write_text(HEADER + "0,0,0,0,0,-1,nan\n")
    with pytest.raises(ScanFormatError, match=r"bad.csv: no usable scans \(all skipped as bad; first: .*line 2, "
                                              r"field range: 'nan' is not finite\)"):
        read_csv(c, skip_bad=True)


def test_carmen_truncated_gzip_is_an_error_unless_skipping(tmp_path):
    data = gzip.compress("".join(GOOD * 5000).encode())
    p = tmp_path / "cut.log.gz"
    p.write_bytes(data[: len(data) // 2])
    with pytest.raises(ScanFormatError, match="truncated or corrupt") as e:
        read_carmen(p)
    report = ReadReport()
    scans = read_carmen(p, skip_bad=True, report=report)
    assert 0 < len(scans) < 10000 and report.skipped == 1
    # the error names the line where the damage was met: after every line that was read
    assert e.value.line is not None and report.errors[0].line == e.value.line
    assert max(int(s.source.rsplit(":", 1)[1]) for s in scans) < e.value.line


@pytest.mark.parametrize("name", ["bad.log.gz", "bad.csv.gz"])
def test_gzip_with_corrupt_compressed_data_is_an_error_not_a_traceback(tmp_path, name):
    # a damaged block inside the stream (not a cut-off end): before, zlib.error ("invalid block
    # type", "invalid distance too far back") escaped as a traceback, with --skip-bad too
    good = gzip.compress("".join(GOOD * 50).encode())
    p = tmp_path / name
    p.write_bytes(good + good[:10] + b"\xff" * 64)  # a second gzip member whose data is no deflate stream
    with pytest.raises(ScanFormatError, match="truncated or corrupt"):
        read_scans(p)
    if name.endswith(".log.gz"):  # CARMEN keeps what came before the damage when asked to skip
        report = ReadReport()
        assert len(read_scans(p, skip_bad=True, report=report)) > 0 and report.skipped == 1


def test_carmen_pose_is_the_laser_pose_not_the_odometry(tmp_path):
    # FLASER n r_1 ... r_n  x y theta  odom_x odom_y odom_theta  timestamp host logger_timestamp
    p = write_log(tmp_path / "a.log", ["FLASER 3 1.0 2.0 3.0 1.5 2.5 0.25 7.0 8.0 -1.0 12.5 host 99.0\n"])
    report = ReadReport()
    (s,) = read_carmen(p, report=report)
    assert s.pose.tolist() == [1.5, 2.5, 0.25] and s.timestamp == 12.5
    assert report.scans == 1 and report.max_range == 3.0  # no explicit maximum: the log's largest range


def test_carmen_zero_range_is_read_as_no_return(tmp_path):
    # 0 is no measurement, not an impossible value: the beam returned nothing (Scan.returns)
    p = write_log(tmp_path / "a.log", [flaser([1.0, 0.0, 2.0])])
    (s,) = read_carmen(p, max_range=81.83)
    assert s.ranges.tolist() == [1.0, 0.0, 2.0] and s.returns.tolist() == [True, False, True]


def test_a_report_shared_by_several_reads_describes_each_file(tmp_path):
    """A report may come with earlier reads in it: an error about this file counts and quotes this
    file's skips only."""
    report = ReadReport()
    read_carmen(write_log(tmp_path / "first.log", [GOOD[3], flaser([1.0, -1.0, 2.0])]), skip_bad=True, report=report)
    assert report.skipped == 1
    with pytest.raises(ScanFormatError, match=r"empty.log: no FLASER, ROBOTLASER1 or RAWLASER1 scans in this file$"):
        read_carmen(write_log(tmp_path / "empty.log", ["# nothing\n"]), skip_bad=True, report=report)
    with pytest.raises(ScanFormatError, match=r"bad.log: no usable FLASER scans: all 1 were skipped as bad "
                                              r"\(first: .*bad.log, line 1, field r_1"):
        read_carmen(write_log(tmp_path / "bad.log", [flaser([float("nan"), 1.0])]), skip_bad=True, report=report)


def test_carmen_empty_and_missing_files(tmp_path):
    p = write_log(tmp_path / "empty.log", ["# nothing\n", "ODOM 0 0 0 0 0 0 0 h 0\n"])
    with pytest.raises(ScanFormatError, match="no FLASER, ROBOTLASER1 or RAWLASER1 scans"):
        read_carmen(p)
    with pytest.raises(ScanFormatError, match="no such file"):
        read_scans(tmp_path / "missing.log")


def test_csv_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(1)
    scans = [
        Scan(rng.uniform(0.1, 9.0, 11), even_bearings(11), rng.normal(size=3), float(k), 8.0, "")
        for k in range(4)
    ]
    p = tmp_path / "s.csv"
    write_csv(p, scans)
    back = read_csv(p)
    assert len(back) == 4
    for a, b in zip(scans, back):
        assert np.array_equal(a.ranges, b.ranges) and np.array_equal(a.bearings, b.bearings)
        assert np.array_equal(a.pose, b.pose) and a.timestamp == b.timestamp and b.max_range == 8.0
    # and through the dispatcher, gzip-compressed
    gz = tmp_path / "s.csv.gz"
    gz.write_bytes(gzip.compress(p.read_bytes()))
    assert len(read_scans(gz)) == 4


HEADER = "scan,time,x,y,theta,bearing,range\n"


@pytest.mark.parametrize(
    "body, line, field, words",
    [
        ("0,0,0,0,0,-1,1\n0,0,0,0,0,0,nan\n", 4, "range", "not finite"),
        ("0,0,0,0,0,-1,1\n0,0,0,0,0,0,-2\n", 4, "range", "negative"),
        ("0,0,0,0,0,-1,1\n0,0,0,0\n", 4, None, "truncated"),
        # an extra field in a middle row: read silently before, its columns taken as they fell
        ("0,0,0,0,0,-1,1\n0,0,0,0,0,0,1,5\n0,0,0,0,0,1,1\n", 4, None, "8 columns, but the header has 7"),
        # decimal commas in every row: before, a misleading "bearings must increase"
        ("0,0,0,0,0,-1,5,1,5\n0,0,0,0,0,0,5,1,5\n", 3, None, "9 columns, but the header has 7"),
        ("0,0,0,0,0,-1,1\n0,0,0,0,0,zero,1\n", 4, "bearing", "not a number"),
        ("0,0,0,0,0,-1,1\n0,0,0.5,0,0,0,1\n", 4, "x", "changes within scan"),
        ("0,0,0,0,0,-1,1\n0,0.1,0,0,0,0,1\n", 4, "time", "changes within scan"),
        ("0,0,0,0,0,-1,1\n0,0,0,0,0,0,1\n0,0,0,0,0.1,1,1\n", 5, "theta", "changes within scan"),
        ("0,0,0,0,0,-1,1\n0,0,0,0,0,-1,1\n", 4, "bearing", "must increase"),
        ("0,0,0,0,0,0,1\n0,0,0,0,0,-1,1\n", 4, "bearing", "must increase"),
        ("0,0,0,0,0,-1,1\n1,1,0,0,0,-1,1\n0,2,0,0,0,-1,1\n", 5, "scan", "not consecutive"),
    ],
)
def test_csv_bad_rows_name_line_and_column(tmp_path, body, line, field, words):
    p = tmp_path / "bad.csv"
    p.write_text("# max_range: 8\n" + HEADER + body)  # line 1 directive, line 2 header, rows from line 3
    with pytest.raises(ScanFormatError) as e:
        read_csv(p)
    assert e.value.line == line and e.value.field == field and words in str(e.value)
    assert "bad.csv" in str(e.value)


def test_csv_header_and_directive_errors(tmp_path):
    p = tmp_path / "h.csv"
    p.write_text("scan,time,x,y,bearing,range\n0,0,0,0,0,1\n")
    with pytest.raises(ScanFormatError, match="lacks column.*theta"):
        read_csv(p)
    p.write_text("# max_range: -3\n" + HEADER + "0,0,0,0,0,0,1\n")
    with pytest.raises(ScanFormatError, match="max_range"):
        read_csv(p)
    for bad in ("0", "nan", "metres"):  # the directive's line is named, not a scan that inherits it
        p.write_text(f"# max_range: {bad}\n" + HEADER + "0,0,0,0,0,0,1\n")
        with pytest.raises(ScanFormatError, match=f"max_range '{bad}' is not a positive number") as e:
            read_csv(p)
        assert e.value.line == 1
    p.write_text("")
    with pytest.raises(ScanFormatError, match="empty"):
        read_csv(p)
    p.write_text("# max_range: 8\n" + HEADER + "\n# no rows\n")
    with pytest.raises(ScanFormatError, match="no scan rows after the header") as e:
        read_csv(p)
    assert e.value.line == 2
    p.write_bytes(b"\x1f\x8b" + b"not really gzip" * 10)
    with pytest.raises(ScanFormatError, match="h.csv: gzip stream is truncated or corrupt"):
        read_csv(p)


def test_csv_skip_bad_and_max_range(tmp_path):
    p = tmp_path / "s.csv"
    p.write_text("# max_range: 5\n" + HEADER + "0,0,0,0,0,-1,1\n0,0,0,0,0,0,9\n1,1,0,0,0,-1,nan\n2,2,0,0,0,-1,4\n")
    report = ReadReport()
    scans = read_csv(p, skip_bad=True, report=report)
    assert len(scans) == 2 and report.skipped == 1
    assert scans[0].returns.tolist() == [True, False]  # 9 >= max_range 5: no return


def test_csv_columns_in_any_order_with_comments_and_other_columns(tmp_path):
    # the format: columns in any order, other columns ignored, lines starting with # are comments
    p = tmp_path / "s.csv"
    p.write_text("Range,Bearing,intensity,Theta,Y,X,Time,Scan\n"
                 "2.5,-0.5,100,0.25,2.0,1.0,7.0,0\n"
                 "# a comment between rows\n"
                 "3.5,0.5,90,0.25,2.0,1.0,7.0,0\n"
                 "  # and an indented one\n"
                 "1.0,0.0,80,0.0,0.0,0.0,8.0,1\n")
    a, b = read_csv(p)
    assert a.ranges.tolist() == [2.5, 3.5] and a.bearings.tolist() == [-0.5, 0.5]
    assert a.pose.tolist() == [1.0, 2.0, 0.25] and a.timestamp == 7.0
    assert b.ranges.tolist() == [1.0] and b.timestamp == 8.0


def test_csv_scans_are_grouped_by_their_scan_column(tmp_path):
    # two lasers sampled at the same time are two scans: the scan column groups rows, not the time
    p = tmp_path / "s.csv"
    p.write_text(HEADER + "0,5.0,0,0,0,-1,1\n0,5.0,0,0,0,1,1\n1,5.0,0,0,0,-1,2\n1,5.0,0,0,0,1,2\n")
    assert [s.ranges.tolist() for s in read_csv(p)] == [[1.0, 1.0], [2.0, 2.0]]


def test_csv_max_range_from_the_caller_the_directive_or_none(tmp_path):
    p = tmp_path / "s.csv"
    p.write_text("# max_range: 8\n" + HEADER + "0,0,0,0,0,-1,5\n0,0,0,0,0,1,9\n")
    report = ReadReport()
    assert read_csv(p, report=report)[0].returns.tolist() == [True, False] and report.max_range == 8.0
    # the caller's maximum wins over the file's, as --max-range does for every format
    (s,) = read_csv(p, max_range=4.0)
    assert s.max_range == 4.0 and s.returns.tolist() == [False, False]
    # without the directive every range is a return, however long
    p.write_text(HEADER + "0,0,0,0,0,-1,5\n0,0,0,0,0,1,1e6\n")
    assert read_csv(p)[0].returns.tolist() == [True, True]


def test_csv_writer_refuses_mixed_max_ranges_and_writes_atomically(tmp_path, monkeypatch):
    b = even_bearings(3)
    scans = [Scan(np.ones(3), b, np.zeros(3), 0.0, 8.0), Scan(np.ones(3), b, np.zeros(3), 1.0, 10.0)]
    p = tmp_path / "s.csv"
    with pytest.raises(ValueError, match="share max_range"):  # one "# max_range:" line cannot say both
        write_csv(p, scans)
    assert not p.exists()
    write_csv(p, scans[:1])
    before = p.read_bytes()

    def full(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr("fuzzybrep.formats.files.os.fsync", full)
    with pytest.raises(MapFileError, match="s.csv: cannot write: No space left"):
        write_csv(p, scans[1:])
    assert p.read_bytes() == before and [f.name for f in tmp_path.iterdir()] == ["s.csv"]


def test_csv_scans_under_another_name_are_recognised_by_their_first_lines(tmp_path):
    # before: the format came from the name alone (although detect_format said "and the first
    # bytes"), so scans.txt, or run.gz from `gzip run.csv && mv`, was "no FLASER scans in this file"
    scans = [Scan(np.full(11, 2.0), even_bearings(11), (0.0, 0.0, 0.0), 1.0, 8.0, "")]
    write_csv(tmp_path / "s.csv", scans)
    text = (tmp_path / "s.csv").read_bytes()
    (tmp_path / "scans.txt").write_bytes(text)
    (tmp_path / "run.gz").write_bytes(gzip.compress(text))
    (tmp_path / "bare.dat").write_bytes(text.split(b"\n", 2)[2])  # no comment lines: the header decides
    for name in ("scans.txt", "run.gz", "bare.dat"):
        (s,) = read_scans(tmp_path / name)
        assert np.array_equal(s.ranges, scans[0].ranges), name
    assert len(read_scans(write_log(tmp_path / "a.txt", GOOD))) > 0  # a CARMEN log is still one


def test_unknown_format_is_refused(tmp_path):
    p = write_log(tmp_path / "a.log", GOOD)
    with pytest.raises(ScanFormatError, match="a.log: unknown scan format 'xml' \\(carmen, csv or rosbag\\)"):
        read_scans(p, fmt="xml")


def test_empty_scan_is_refused():
    with pytest.raises(ScanValueError):
        Scan(np.array([1.0, np.nan]), np.array([0.0, 0.1]), np.zeros(3))
    with pytest.raises(ScanValueError, match="increase"):
        Scan(np.array([1.0, 1.0]), np.array([0.1, 0.0]), np.zeros(3))


def test_consolidation_of_two_180_degree_scans():
    b = even_bearings(181)  # LMS200: 181 beams over 180° at 1°
    front = Scan(np.full(181, 2.0), b, np.array([1.0, 1.0, 0.3]), 5.0, 8.0, "front")
    back = Scan(np.full(181, 3.0), b, np.array([1.0, 1.0, 0.3 + np.pi]), 6.0, 8.0, "back")
    s = consolidate(front, back)
    assert s.full_circle
    assert len(s.ranges) == 360  # the two beams at ±90° are seen by both: kept once
    assert np.allclose(np.diff(s.bearings), np.radians(1))
    assert np.isclose(s.bearings[0], -np.pi / 2) and np.isclose(s.bearings[-1], np.radians(269))
    # front beams keep their ranges; the back scan fills the other half
    assert np.all(s.ranges[:181] == 2.0) and np.all(s.ranges[181:] == 3.0)
    # the same world points: a back beam's endpoint lies where the back scan saw it
    back_end = back.endpoints()[90]  # straight behind the front scan's heading
    k = np.argmin(np.abs(s.bearings - np.pi))
    assert np.allclose(s.endpoints()[k], back_end)


def test_full_circle_is_judged_by_the_turn_the_beams_cover():
    # four beams 90° apart cover the turn; three over 180° (CARMEN's -90°..+90°) do not
    assert Scan(np.ones(4), [-np.pi, -np.pi / 2, 0.0, np.pi / 2], np.zeros(3)).full_circle
    assert not Scan(np.ones(3), even_bearings(3), np.zeros(3)).full_circle
    assert not Scan(np.ones(181), even_bearings(181), np.zeros(3)).full_circle


def test_consolidation_turns_the_back_scan_by_the_heading_it_had():
    """A back scan turned 175° (within the tolerance of a 180° turn): its beams keep their world
    directions, and a beam at or beyond either scan's max_range stays no return."""
    b = even_bearings(181)
    rng = np.random.default_rng(0)
    front = Scan(rng.uniform(1.0, 3.0, 181), b, np.array([1.0, 1.0, 0.3]), 5.0, 8.0, "front")
    r = rng.uniform(1.0, 3.0, 181)
    r[100] = 9.0  # beyond the front scan's maximum, below the back scan's: a return only to the back scan
    back = Scan(r, b, np.array([1.0, 1.0, 0.3 + np.radians(175)]), 6.0, 10.0, "back")
    s = consolidate(front, back)
    assert len(s.ranges) > 181
    # every beam taken from the back scan ends where the back scan saw it
    gap = np.hypot(*(s.endpoints()[181:, None, :] - back.endpoints()[None, :, :]).transpose(2, 0, 1)).min(axis=1)
    assert gap.max() < 1e-9
    assert s.max_range == 8.0 and s.returns[:181].all() and not s.returns[s.ranges == 9.0].any()


def test_consolidation_refuses_scans_from_different_spots():
    b = even_bearings(181)
    a = Scan(np.ones(181), b, np.array([0.0, 0.0, 0.0]))
    moved = Scan(np.ones(181), b, np.array([1.0, 0.0, np.pi]))
    same_heading = Scan(np.ones(181), b, np.array([0.0, 0.0, 0.1]))
    with pytest.raises(ScanValueError, match="cannot consolidate"):
        consolidate(a, moved, position_tol=0.05)
    merged, n = consolidate_pairs([a, same_heading, a, Scan(np.ones(181), b, np.array([0.01, 0.0, np.pi]))])
    assert n == 1 and len(merged) == 3 and merged[-1].full_circle
    # 20 cm apart with position_tol 5 cm, or turned 150°: not one spot facing the other way
    near = Scan(np.ones(181), b, np.array([0.2, 0.0, np.pi]))
    turned = Scan(np.ones(181), b, np.array([0.0, 0.0, np.radians(150)]))
    assert consolidate_pairs([a, near], position_tol=0.05)[1] == 0
    assert consolidate_pairs([a, turned])[1] == 0
    # 360° scans are whole already
    whole = consolidate(a, Scan(np.ones(181), b, np.array([0.0, 0.0, np.pi])))
    whole_back = Scan(whole.ranges, whole.bearings, np.array([0.0, 0.0, np.pi]))
    assert consolidate_pairs([whole, whole_back])[1] == 0


def test_real_logs_read_with_their_sentinels():
    for name, n, beams, sentinel in [("intel", 910, 180, 81.83), ("aces", 440, 180, 50.0)]:
        scans = read_scans(log_path(name))
        assert len(scans) == n and {len(s.ranges) for s in scans} == {beams}
        assert scans[0].max_range == sentinel
        # the sentinel marks the no-return beams, which are a small minority
        returns = sum(int(s.returns.sum()) for s in scans)
        assert 0.9 * n * beams < returns < n * beams


@pytest.mark.parametrize("kw, words", [
    # before: all accepted; a NaN bearing passed "bearings must increase strictly" (NaN compares false),
    # a NaN max_range made every beam "no return", and a scan with no beams failed deep in build_map
    # with NumPy's "zero-size array to reduction operation minimum"
    (dict(bearings=[0.0, float("nan"), 0.2]), "s.log:3: beam 1 has bearing nan (not finite)"),
    (dict(timestamp=float("nan")), "s.log:3: timestamp nan is not finite"),
    (dict(max_range=float("nan")), "s.log:3: max_range nan must be positive (inf: every range is a return)"),
    (dict(max_range=-1.0), "s.log:3: max_range -1.0 must be positive"),
    (dict(ranges=[], bearings=[]), "s.log:3: a scan needs at least one beam"),
    (dict(bearings=[0.0, 0.1]), "s.log:3: 3 ranges but 2 bearings"),
    (dict(pose=[0.0, 0.0]), "s.log:3: pose must be (x, y, heading), got (2,)"),
    (dict(pose=[0.0, float("nan"), 0.0]), "s.log:3: pose is not finite: [0.0, nan, 0.0]"),
    (dict(ranges=[1.0, 2.0, -0.5]), "s.log:3: beam 2 has range -0.5 (NaN, infinite or negative)"),
    (dict(ranges=[1.0, float("inf"), 3.0]), "s.log:3: beam 1 has range inf (NaN, infinite or negative)"),
    (dict(bearings=[0.0, 0.1, 0.1]), "s.log:3: bearings must increase strictly"),
    (dict(bearings=np.linspace(0.0, 2 * np.pi, 3)), "s.log:3: bearings span a full turn or more"),
])
def test_scan_refuses_impossible_values(kw, words):
    args = dict(ranges=[1.0, 2.0, 3.0], bearings=[0.0, 0.1, 0.2], pose=[0.0, 0.0, 0.0], source="s.log:3") | kw
    with pytest.raises(ScanValueError) as e:
        Scan(**args)
    assert str(e.value) == words or str(e.value).startswith(words), str(e.value)
