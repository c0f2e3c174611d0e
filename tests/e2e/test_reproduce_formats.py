"""``reproduce --format``: the experiment's figure as PNG (the default), PDF or SVG, linked by
report.md, with the same CSV whatever the format; a format that is not one, or one that
``--runs-only`` would not use, is one line and exit code 1 before any work."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from PIL import Image

from adaptsky_cli.cli.main import main
from tests.helpers.cli import one_line
from tests.helpers.reproduce import curves_experiment

SHORT = ["--episodes", "2", "--steps", "10", "--workers", "1", "--quiet"]



def test_figure_formats(tmp_path, capsys):
    experiment = curves_experiment(tmp_path, runs=1)
    out = tmp_path / "out"
    assert main(["reproduce", str(experiment), "--out", str(out), *SHORT]) == 0
    with Image.open(out / "tiny.png") as image:
        assert image.format == "PNG" and image.size == (1050, 675)
    assert "![tiny](tiny.png)" in (out / "report.md").read_text()
    numbers = (out / "tiny.csv").read_bytes()
    # a second call only redraws, in the format asked for (PDF: tests/unit/report)
    assert main(["reproduce", str(experiment), "--out", str(out), *SHORT, "--format", "SVG"]) == 0
    report = (out / "report.md").read_text()
    assert "![tiny](tiny.svg)" in report and "tiny.png" not in report
    assert (out / "tiny.csv").read_bytes() == numbers
    assert ET.parse(out / "tiny.svg").getroot().tag == "{http://www.w3.org/2000/svg}svg"
    capsys.readouterr()
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    assert main(["reproduce", str(experiment), "--out", str(out), *SHORT,
                 "--format", "jpeg"]) == 2
    assert one_line(capsys) == ("adaptsky reproduce: --format: 'jpeg' is not a figure format; "
                                "choose from png, pdf, svg; see 'adaptsky reproduce --help'")
    assert main(["reproduce", str(experiment), "--out", str(out), *SHORT, "--runs-only",
                 "--format", "pdf"]) == 2
    assert one_line(capsys) == ("adaptsky reproduce: --format pdf: --runs-only draws no "
                                "figure; leave out one of them; see 'adaptsky reproduce --help'")
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before


def test_a_bad_format_is_refused_before_training(tmp_path, capsys):
    experiment = curves_experiment(tmp_path, runs=1)
    out = tmp_path / "never"
    for target in (str(experiment), "all"):
        assert main(["reproduce", target, "--out", str(out), *SHORT, "--format", "eps"]) == 2
        assert one_line(capsys) == ("adaptsky reproduce: --format: 'eps' is not a figure "
                                    "format; choose from png, pdf, svg; see 'adaptsky reproduce "
                                    "--help'")
    assert not Path(out).exists()
