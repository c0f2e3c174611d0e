"""Figure files: PNG, PDF and SVG written whole and read back (PNG by PIL, PDF by its header and
fonts, SVG as XML), the same figure giving the same bytes, and a suffix or format name that is
not a figure format refused in one line."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from PIL import Image

from adaptsky.errors import AdaptskyError
from adaptsky.report.figure_files import FIGURE_FORMATS, check_format, format_of, save_figure
from adaptsky.report.figures import Level, learning_curves
from tests.helpers.report import two_series


def figure():
    return learning_curves(two_series(), [Level("SoA", 31.8e9)], title="E3",
                           note="$J_e$ at the last episode: 0.61 ± 0.02")


@pytest.mark.parametrize("kind", FIGURE_FORMATS)
def test_each_format_is_written_whole_and_reads_back(kind, tmp_path):
    path = save_figure(figure(), tmp_path / f"fig.{kind}")
    data = path.read_bytes()
    if kind == "png":
        with Image.open(path) as image:
            assert image.format == "PNG" and image.size == (1050, 675)  # 7 x 4.5 in at 150 dpi
    elif kind == "pdf":
        assert data.startswith(b"%PDF")
        assert b"/Type3" not in data and b"/CIDFontType2" in data  # TrueType, not Type 3 fonts
        assert b"/CreationDate" not in data
    else:
        root = ET.fromstring(data)
        assert root.tag == "{http://www.w3.org/2000/svg}svg"
        assert b"<dc:date>" not in data
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary copy left


@pytest.mark.parametrize("kind", FIGURE_FORMATS)
def test_the_same_figure_gives_the_same_bytes(kind, tmp_path):
    first = save_figure(figure(), tmp_path / f"a.{kind}").read_bytes()
    again = save_figure(figure(), tmp_path / f"b.{kind}").read_bytes()
    assert first == again


def test_the_suffix_names_the_format():
    assert [format_of(Path(f"x/fig.{s}")) for s in ("png", "PDF", "Svg")] == ["png", "pdf",
                                                                            "svg"]
    for path, given in ((Path("run.h5"), "'.h5'"), (Path("figure"), "no suffix"),
                        (Path("fig.jpg"), "'.jpg'")):
        with pytest.raises(AdaptskyError) as error:
            format_of(path)
        assert str(error.value) == (f"--out {path}: a figure file must end in .png, .pdf or "
                                    f".svg (it has {given})")


def test_format_names(tmp_path):
    assert check_format("PDF") == "pdf"
    with pytest.raises(AdaptskyError, match=r"^--format jpeg: not a figure format; choose png, "
                                            r"pdf or svg$"):
        check_format("jpeg")
    with pytest.raises(AdaptskyError, match="must end in"):
        save_figure(figure(), tmp_path / "fig.eps")
    assert list(tmp_path.iterdir()) == []
