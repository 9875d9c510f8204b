"""`uuvid examples`: the generated example logs are what they say, and the README's chain of
commands on them gives clear results and clear errors."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.examples import EXAMPLES, generate_example, write_example
from uuvid.vehicle.definition import load_vehicle

runner = CliRunner()


@pytest.mark.slow
def test_every_example_is_deterministic_and_written_as_named(tmp_path):
    import fnmatch

    for name, e in EXAMPLES.items():
        a, b = generate_example(name), generate_example(name)
        files_a = a if e.multi else {e.filename: a}
        files_b = b if e.multi else {e.filename: b}
        assert list(files_a) == list(files_b)
        paths = write_example(name, tmp_path / name)
        assert [p.name for p in paths] == list(files_a)
        for p in paths:
            assert fnmatch.fnmatch(p.name, e.filename)
            cols, again = files_a[p.name], files_b[p.name]
            # logs are time series; a steady bench sweep (one row per operating point) is not
            assert list(cols) == list(again) and (({"time", "t", "t_s"} & set(cols))
                                                  or name == "thruster-flow")
            for k in cols:
                x, y = np.asarray(cols[k]), np.asarray(again[k])
                assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), k
            lines = p.read_text().splitlines()
            assert lines[0].split(",") == list(cols)
            assert len(lines) == len(next(iter(cols.values()))) + 1


@pytest.mark.slow
def test_cli_lists_and_writes_examples(tmp_path):
    res = runner.invoke(app, ["examples", "--list"])
    assert res.exit_code == 0
    for name in EXAMPLES:
        assert name in res.stdout
    res = runner.invoke(app, ["examples", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    import fnmatch

    written = sorted(p.name for p in tmp_path.iterdir())
    for e in EXAMPLES.values():
        assert any(fnmatch.fnmatch(n, e.filename) for n in written), e.filename
    assert all(any(fnmatch.fnmatch(n, e.filename) for e in EXAMPLES.values()) for n in written)
    res = runner.invoke(app, ["examples", "no-such", "--out", str(tmp_path)])
    assert res.exit_code == 2 and "no-such" in res.output and "yaw-steady" in res.output


@pytest.mark.slow
def test_steady_example_identifies_the_simulated_romeo_and_feeds_inertia(tmp_path):
    write_example("yaw-steady", tmp_path)
    write_example("yaw-sine", tmp_path)
    cols = ["--dof", "yaw", "--command-col", "torque", "--position-col", "heading_deg",
            "--angle-unit", "deg"]
    rep = tmp_path / "yaw-report"
    res = runner.invoke(app, ["vehicle", "identify", "steady", str(tmp_path / "yaw_steady.csv"), *cols,
                              "--mode-col", "mode", "--open-water-mode", "yaw_fl_rr+",
                              "--report", str(rep), "--json"])
    assert res.exit_code == 0, res.output
    p = json.loads(res.stdout)["parameters"]
    truth = load_vehicle("romeo").one_dof["yaw"]
    for name, value in (("k", truth.linear), ("k_q", truth.quadratic)):
        assert abs(p[name]["estimate"] - value) <= 3 * p[name]["sigma"], (name, p[name], value)
    # the report's summary.json is what `identify inertia --drag` takes (no shell redirect)
    res = runner.invoke(app, ["vehicle", "identify", "inertia", str(tmp_path / "yaw_sine.csv"), *cols,
                              "--drag", str(rep / "summary.json"), "--json"])
    assert res.exit_code == 0, res.output
    m = json.loads(res.stdout)["parameters"]["m"]
    assert abs(m["estimate"] - truth.mass) <= 3 * m["sigma"]
    # an empty JSON (what `> steady.json` leaves when the command failed) is named as such
    empty = tmp_path / "yaw.json"
    empty.write_text("")
    res = runner.invoke(app, ["vehicle", "identify", "inertia", str(tmp_path / "yaw_sine.csv"), *cols,
                              "--drag", str(empty)])
    assert res.exit_code == 2 and "yaw.json" in res.output and "empty" in res.output


def test_examples_never_overwrite_a_users_file(tmp_path):
    """``uuvid examples yaw-sine --out all`` replaced ``all/yaw_sine.csv`` holding the user's data
    silently: a file of another content is refused (nothing written, the file named, --force
    said); the same example written again (identical content) is no clash; --force overwrites."""
    mine = tmp_path / "yaw_sine.csv"
    mine.write_text("time,torque,heading_deg\n0,1,2\n")
    res = runner.invoke(app, ["examples", "yaw-steady", "yaw-sine", "--out", str(tmp_path)])
    text = " ".join(res.output.split())
    assert res.exit_code == 2, res.output
    assert "yaw_sine.csv" in text and "--force" in text and "nothing was written" in text
    assert mine.read_text() == "time,torque,heading_deg\n0,1,2\n"
    assert not (tmp_path / "yaw_steady.csv").exists()  # all or nothing
    with pytest.raises(FileExistsError, match="yaw_sine.csv"):
        write_example("yaw-sine", tmp_path)
    assert mine.read_text() == "time,torque,heading_deg\n0,1,2\n"
    # the same example again: identical content, no clash
    res = runner.invoke(app, ["examples", "yaw-steady", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["examples", "yaw-steady", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["examples", "yaw-sine", "--out", str(tmp_path), "--force"])
    assert res.exit_code == 0, res.output
    assert mine.read_text().startswith("time,torque,heading_deg\n0,-5,")


def test_examples_out_naming_a_file_says_a_folder_is_expected(tmp_path):
    """``--out afile`` said "cannot write yaw_sine.csv (File exists)"; it is a file where the
    folder goes, said as ``simulate --out`` says it."""
    f = tmp_path / "afile"
    f.write_text("keep")
    res = runner.invoke(app, ["examples", "yaw-sine", "--out", str(f)])
    text = " ".join(res.output.split())
    assert res.exit_code == 2
    assert f"--out {f}" in text and "a folder was expected" in text, text
    assert f.read_text() == "keep"



def test_a_write_failing_partway_rolls_back_the_examples_already_written(tmp_path, monkeypatch):
    """The clash check comes first, the writes after: a write that fails on a later file (a full
    disk, a read-only file) puts the set back as it was — a new file removed, one replaced with
    --force given its old bytes again — and says so."""
    import uuvid.examples as ex
    from uuvid.core import atomic

    real, calls = atomic.atomic_write_text, []

    def flaky(path, text, *a, **k):
        calls.append(path)
        if len(calls) in (2, 4):
            raise OSError(28, "No space left on device", str(path))
        return real(path, text, *a, **k)

    monkeypatch.setattr(atomic, "atomic_write_text", flaky)
    with pytest.raises(OSError, match="rolled back") as e:
        ex.write_examples(list(EXAMPLES)[:2], tmp_path)
    assert str(calls[0]) in str(e.value) and e.value.errno == 28
    assert not calls[0].exists(), "a new example was left behind by a failed set"
    calls[0].write_text("the user's own file")
    with pytest.raises(OSError, match="rolled back"):
        ex.write_examples(list(EXAMPLES)[:2], tmp_path, overwrite=True)
    assert calls[2] == calls[0] and calls[0].read_text() == "the user's own file"
