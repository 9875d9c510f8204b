"""``thruster export --out-file``, ``thruster fit --out-model``/``--report`` and ``thruster simulate
--out`` into a folder that does not exist: the folders to be made are said first
(``/nonexistent/dir`` was created at the root without a word), none made by a run that fails."""

from __future__ import annotations

from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()

BENCH = "command,thrust\n" + "".join(f"{c},{(c - 1500) * abs(c - 1500) * 1e-4:.6g}\n"
                                     for c in range(1100, 1901, 50))


def test_export_into_a_missing_folder_says_it_creates_it(tmp_path):
    """A mistyped path (/nonexistent/dir/x.yaml) made a tree of folders without a word: the
    folders that do not exist yet are said before anything is written."""
    target = tmp_path / "no" / "such" / "x.yaml"
    res = runner.invoke(app, ["thruster", "export", "t200", "--out-file", str(target)])
    assert res.exit_code == 0, res.stderr
    assert f"--out-file {target}: the folder {tmp_path / 'no'} does not exist yet; it will be created" \
        in " ".join(res.stderr.split())
    assert target.is_file()
    ok = runner.invoke(app, ["thruster", "export", "t200", "--out-file", str(tmp_path / "x.yaml")])
    assert ok.exit_code == 0 and (tmp_path / "x.yaml").is_file() and "does not exist" not in ok.stderr


def test_fit_says_a_missing_folder_for_the_model_and_makes_none_when_it_fails(tmp_path):
    f = tmp_path / "b.csv"
    f.write_text(BENCH.replace("1700,4", "1700,nan"))
    target = tmp_path / "no" / "o.yaml"
    res = runner.invoke(app, ["thruster", "fit", str(f), "--thrust-col", "thrust", "--model",
                              "cv", "--out-model", str(target)])
    assert res.exit_code == 2, res.stderr
    assert f"--out-model {target}: the folder {target.parent} does not exist yet" in " ".join(res.stderr.split())
    assert not (tmp_path / "no").exists()  # the run failed on its input: no empty folder left


def test_fit_with_an_absurd_thrust_writes_nothing_and_leaks_no_warning(tmp_path):
    f = tmp_path / "huge.csv"
    f.write_text(BENCH.replace("1700,4", "1700,1e300").replace("1800,9", "1800,1e300"))
    assert "1e300" in f.read_text()
    res = runner.invoke(app, ["thruster", "fit", str(f), "--thrust-col", "thrust", "--model",
                              "cv", "--out-model", str(tmp_path / "o.yaml")])
    assert res.exit_code == 2
    assert "huge.csv: column 'thrust', data row" in res.stderr
    assert "RuntimeWarning" not in res.stderr and "overflow" not in res.stderr
    assert not (tmp_path / "o.yaml").exists()


def test_simulate_and_fit_report_say_a_missing_parent_folder(tmp_path):
    out = tmp_path / "no" / "sim"
    res = runner.invoke(app, ["thruster", "simulate", "t200", "--out", str(out)])
    assert res.exit_code == 0 and f"the folder {out.parent} does not exist yet" in " ".join(res.stderr.split())
    assert (out / "index.html").is_file()
    # the report folder itself is made
    v = tmp_path / "v.csv"
    v.write_text("command,thrust\n" + "".join(f"{c},{c * abs(c) * 0.1:.6g}\n" for c in range(-12, 13)))
    res = runner.invoke(app, ["thruster", "fit", str(v), "--thrust-col", "thrust", "--model", "cv",
                              "--command-unit", "volts", "--out-model", str(tmp_path / "o.yaml"),
                              "--report", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.stderr
    assert (tmp_path / "rep" / "index.html").is_file()
