"""profile.csv as spreadsheets save it: a byte-order mark, Windows line ends and trailing
blank lines read the same profile as the plain file; a binary file is one line naming it."""

import numpy as np
import pytest

from updating.model.profile import read_profile_csv

PLAIN = "x_in,diameter_in\n0.0,1.50\n1.0,1.10\n12.0,0.95\n24.0,2.40\n34.0,2.55\n"


@pytest.mark.parametrize("variant", ["bom", "crlf", "blank_tail", "all"])
def test_spreadsheet_csv_reads_as_the_plain_file(tmp_path, variant):
    text = PLAIN
    if variant in ("crlf", "all"):
        text = text.replace("\n", "\r\n")
    if variant in ("blank_tail", "all"):
        text += "\r\n\r\n" if variant == "all" else "\n\n,\n"
    data = text.encode("utf-8")
    if variant in ("bom", "all"):
        data = b"\xef\xbb\xbf" + data
    (tmp_path / "plain.csv").write_text(PLAIN)
    (tmp_path / "odd.csv").write_bytes(data)
    a, b = read_profile_csv(tmp_path / "plain.csv"), read_profile_csv(tmp_path / "odd.csv")
    np.testing.assert_array_equal(a.x_m, b.x_m)
    np.testing.assert_array_equal(a.diameter_m, b.diameter_m)


def test_a_binary_file_is_one_line_naming_it(tmp_path):
    path = tmp_path / "profile.csv"
    path.write_bytes(b"\xff\xfe\x00\x01binary")
    with pytest.raises(ValueError, match=r"profile\.csv: not a text file"):
        read_profile_csv(path)
