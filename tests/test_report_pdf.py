"""`batlab report --pdf` and `batlab lab` (issue 50): the lab profile in the certificate, the
PDF printed by headless Chromium, and one line on stderr, exit 2, without a browser."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from batlab.cli import main
from batlab.lab import lab_rows, read_lab
from batlab.report import find_chromium

SAMPLE = Path("data_samples/smooth_bat")


def run_cli(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_lab_profile_is_kept_and_checked(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BATLAB_LAB", str(tmp_path / "lab.json"))
    assert read_lab() is None and "no lab profile" in lab_rows(None)[0][1]
    code, out, _ = run_cli(["lab", "--name", "Test Lab", "--operator", "J. Doe",
                            "--band", "20", "3000", "--averages", "5"], capsys)
    assert code == 0 and "Laboratory: Test Lab" in out and "Analysis band (Hz): 20–3000" in out
    code, out, _ = run_cli(["lab", "--hammer", "PCB 086C03", "--json"], capsys)
    assert json.loads(out) == {"name": "Test Lab", "operator": "J. Doe",
                               "band_hz": [20.0, 3000.0], "averages": 5,
                               "hammer": "PCB 086C03"}
    (tmp_path / "lab.json").write_text('{"name": "x", "colour": "red"}')
    code, out, err = run_cli(["lab"], capsys)
    assert code == 2 and out == "" and "lab.json: unknown key 'colour'" in err
    assert err.count("\n") == 1


def test_pdf_without_chromium_says_so_at_once(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("BATLAB_CHROMIUM", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path))  # no browser on it
    with pytest.raises(ValueError, match="--pdf needs Chromium"):
        find_chromium()
    code, out, err = run_cli(["report", "HX-1", "--pdf", "--db", tmp_path / "none.sqlite",
                              "-o", tmp_path / "r"], capsys)
    assert code == 2 and out == "" and not (tmp_path / "r").exists()
    assert "--pdf needs Chromium" in err and err.count("\n") == 1


@pytest.mark.skipif(not Path("/usr/bin/chromium").exists(), reason="/usr/bin/chromium not "
                    "installed (apt-get install chromium; .ci/run installs it)")
def test_report_pdf_has_pages(tmp_path, monkeypatch):
    """A small page printed through ``write_pdf``: a PDF with its pages and the print
    stylesheet's page numbers (two forced pages: two page objects)."""
    from batlab.report import write_pdf

    monkeypatch.setenv("BATLAB_CHROMIUM", "/usr/bin/chromium")
    page = tmp_path / "index.html"
    page.write_text("<!DOCTYPE html><html><head><style>@page{@bottom-right{content:'Page ' "
                    "counter(page) ' of ' counter(pages)}}</style></head><body><p>one</p>"
                    "<p style='break-before:page'>two</p></body></html>")
    pdf = write_pdf(page).read_bytes()
    assert pdf.startswith(b"%PDF") and len(re.findall(rb"/Type\s*/Page(?!s)", pdf)) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["index.html", "report.pdf"]
