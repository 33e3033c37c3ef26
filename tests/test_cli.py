"""The demos' argument types: a bad value stops argparse with a message naming it."""

import argparse

import pytest

from fe_mpm.cli import between, nonnegative, positive


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="demo.py")
    p.add_argument("--dt", type=positive(float))
    p.add_argument("--steps", type=positive(int))
    p.add_argument("--alpha", type=nonnegative(float))
    p.add_argument("--ratio", type=between(0.0, 1.0))
    return p


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--dt", "2.5e-3"], ("dt", 2.5e-3)),
        (["--steps", "40"], ("steps", 40)),
        (["--alpha", "0"], ("alpha", 0.0)),
        (["--ratio", "0.999"], ("ratio", 0.999)),
    ],
)
def test_good_values_come_back_as_their_kind(argv, expected):
    name, value = expected
    got = getattr(parser().parse_args(argv), name)
    assert got == value and type(got) is type(value)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--dt", "0"], "argument --dt: must be > 0, got '0'"),
        (["--dt=-1e-3"], "argument --dt: must be > 0, got '-1e-3'"),
        (["--dt", "nan"], "argument --dt: must be > 0, got 'nan'"),
        (["--dt", "inf"], "argument --dt: must be > 0, got 'inf'"),
        (["--dt", "fast"], "argument --dt: not float: 'fast'"),
        (["--steps", "0"], "argument --steps: must be > 0, got '0'"),
        (["--steps", "2.5"], "argument --steps: not int: '2.5'"),
        (["--alpha", "-0.1"], "argument --alpha: must be >= 0, got '-0.1'"),
        (["--ratio", "1"], "argument --ratio: must be in (0, 1), got '1'"),
        (["--ratio", "0"], "argument --ratio: must be in (0, 1), got '0'"),
    ],
)
def test_bad_values_stop_argparse_naming_the_option(argv, message, capsys):
    with pytest.raises(SystemExit) as stop:
        parser().parse_args(argv)
    assert stop.value.code == 2
    assert f"demo.py: error: {message}" in capsys.readouterr().err
