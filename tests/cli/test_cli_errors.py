"""Bad case files: exit code 2, a one-line message on stderr naming file and key, no traceback."""

import pytest
from click.testing import CliRunner

from impactsim.cli import main

GOOD = """\
[run]
end_time = "10 us"

[[body]]
name = "cube"
material = "aluminium-elastic"
shape = "cube12"
size = "2 cm"
"""


def check(tmp_path, text, *args):
    path = tmp_path / "case.toml"
    if text is not None:
        path.write_text(text)
    return CliRunner().invoke(main, ["check", str(path), *args]), str(path)


def assert_clean_failure(result, *fragments):
    assert result.exit_code == 2, result.output
    assert isinstance(result.exception, SystemExit)
    assert "Traceback" not in result.output
    assert result.stdout == ""
    assert result.stderr.startswith("error: ")
    for fragment in fragments:
        assert fragment in result.stderr, result.stderr


def test_good_case_passes(tmp_path):
    result, _ = check(tmp_path, GOOD)
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize("text, fragments", [
    (GOOD.replace("size =", "sise ="),
     ['body[0].sise (body "cube"): ', "unknown key 'sise'", "did you mean 'size'?"]),
    (GOOD.replace('end_time = "10 us"', 'end_time = "10 us'), [": line 2, column ", "invalid TOML"]),
    (GOOD.replace('"10 us"', '"-10 us"'), ["run.end_time: must be > 0"]),
    (GOOD.replace('"2 cm"', '"2 cmm"'), ['body[0].size (body "cube"): unknown unit']),
    (GOOD.replace("aluminium-elastic", "aluminium-elastc"),
     ["did you mean 'aluminium-elastic'?"]),
])
def test_bad_case_exits_2_with_file_and_key(tmp_path, text, fragments):
    result, path = check(tmp_path, text)
    assert_clean_failure(result, f"error: {path}: ", *fragments)


def test_missing_file(tmp_path):
    result, path = check(tmp_path, None)
    assert_clean_failure(result, f"{path}: file not found")


def test_bad_override(tmp_path):
    result, path = check(tmp_path, GOOD, "--set", "run.clf=0.5")
    assert_clean_failure(result, f"{path}: run.clf: unknown key 'clf'", "did you mean 'cfl'?",
                         "(from --set run.clf=0.5)")
