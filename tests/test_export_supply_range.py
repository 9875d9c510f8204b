"""``thruster export --supply-voltage`` outside the voltages the model's data cover is warned about,
naming the range, as ``thruster predict`` and ``vehicle hold --voltage`` do: 160 V (a typo for
16) exported the T200 with a table up to 823.8 N and only an "87 % off" note."""

import re

from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.thruster.presets import preset_chain
from uuvid.thruster.resolve import export_supply

runner = CliRunner()


def test_export_warns_about_a_supply_outside_the_t200_sheets():
    res = runner.invoke(app, ["thruster", "export", "t200", "--to", "uuv-simulator",
                              "--supply-voltage", "160"])
    out = re.sub(r"\s+", " ", res.output)
    assert "warning: supply voltage 160 V is outside the data's 12–16 V" in out, res.output
    assert "T200 sheets" in out


def test_export_within_the_sheets_is_not_warned_about_its_range():
    for v in ("12", "16"):
        res = runner.invoke(app, ["thruster", "export", "t200", "--supply-voltage", v])
        assert res.exit_code == 0, res.output
        assert "outside the data" not in res.output


def test_export_supply_says_the_range_for_presets_and_files():
    _, lines = export_supply("t200", preset_chain("t200"), 160.0)
    assert any(s.startswith("warning: supply voltage 160 V is outside the data's 12–16 V")
               for s in lines)
    _, lines = export_supply("laidani-a2212", preset_chain("laidani-a2212"), 16.0)
    assert any("outside the data's 12 V" in s for s in lines)
    _, lines = export_supply("t200", preset_chain("t200"))  # its own 16 V
    assert not any("outside the data" in s for s in lines)
