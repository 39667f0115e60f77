"""Every lab JSON file is read by one reader: one-line errors naming the file and the problem,
the same wording whichever file it is."""

import pytest

from updating.inspect.retest_meta import read_retest_meta
from updating.model.bar import read_bar_json
from updating.model.json_input import read_json_object
from updating.model.lab_input import read_meta

READERS = [read_json_object, read_meta, read_bar_json, read_retest_meta]
BAD = [
    (None, "no such file"),
    ('{"weight_lb": 2.2', "not valid JSON (Expecting ',' delimiter, line 1)"),
    ("[1, 2]", "expected a JSON object"),
    (b"\xff\xfe\x00{", "not a text file"),
]


@pytest.mark.parametrize("reader", READERS, ids=lambda f: f.__name__)
@pytest.mark.parametrize(("content", "problem"), BAD, ids=[p for _, p in BAD])
def test_unusable_file_is_one_line_naming_it(tmp_path, reader, content, problem):
    path = tmp_path / "lab.json"
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        path.write_text(content)
    with pytest.raises(ValueError) as exc:
        reader(path)
    assert str(exc.value) == f"{path}: {problem}"


def test_an_object_comes_back_as_written(tmp_path):
    path = tmp_path / "meta.json"
    path.write_text('{"serial": "B-1", "points_in": [1, 3.5]}')
    assert read_json_object(path) == {"serial": "B-1", "points_in": [1, 3.5]}
