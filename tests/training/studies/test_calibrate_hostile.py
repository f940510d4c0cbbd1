"""Hostile inputs of ``cdcr-gym calibrate``: a UTF-8 BOM, --start aliases and bad start values,
an implausible tension, a full disk (exit 2, no traceback, nothing half-written)."""

from __future__ import annotations

import errno
from pathlib import Path

import numpy as np
import pytest

from cdcr_gym.calibration import read_csv, write_csv
from cdcr_gym.model.params import RobotParams
from training.studies import calibrate as cli

P = RobotParams()


def _csv(tmp_path: Path, name: str = "d.csv") -> Path:
    """A small measurement CSV of this package's format (T1..T3, x, y, z, sigma)."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "calibration"))
    from test_calibration import _analytic_data  # the calibration tests' synthetic data

    path = tmp_path / name
    write_csv(path, _analytic_data({"youngs_modulus": 30e9}, sigma=2e-5))
    return path


def _main(args: list[str]) -> int:
    try:
        return cli.main(args)
    except SystemExit as exc:
        return int(exc.code)


def test_a_csv_with_a_utf8_bom_reads(tmp_path: Path) -> None:
    plain = _csv(tmp_path)
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    a, b = read_csv(plain, robot=P), read_csv(bom, robot=P)
    np.testing.assert_array_equal(a.tensions, b.tensions)
    np.testing.assert_array_equal(a.tip, b.tip)


@pytest.mark.parametrize("name", ["E", "youngs_modulus"])
def test_start_takes_the_names_and_aliases_of_fit(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "o"
    args = [str(_csv(tmp_path)), "--fit", "E", "--start", f"{name}=2e10", "--out", str(out)]
    assert _main([*args, "--quiet"]) == 0, capsys.readouterr().err
    assert "youngs_modulus" in (out / "params.yaml").read_text()


def test_a_negative_start_value_is_a_usage_error_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "o"
    args = [str(_csv(tmp_path)), "--fit", "E", "--start", "youngs_modulus=-5", "--out", str(out)]
    assert _main(args) == 2
    err = capsys.readouterr().err
    assert "youngs_modulus" in err and "-5" in err and "Traceback" not in err
    assert not out.exists()


def test_a_500_newton_row_is_an_error_naming_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = _csv(tmp_path).read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("T1"))
    row = lines[header + 2].split(",")
    row[0] = "500"
    lines[header + 2] = ",".join(row)
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=rf"bad\.csv line {header + 3}, column 'T1'.*500 N"):
        read_csv(path, robot=P)
    assert _main([str(path), "--fit", "E", "--out", str(tmp_path / "o")]) == 2
    assert f"bad.csv line {header + 3}" in capsys.readouterr().err


def test_a_full_disk_is_exit_2_with_nothing_half_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import cdcr_gym.calibration.report as report

    real = report.plot_residuals

    def full(result, path: Path) -> None:  # type: ignore[no-untyped-def]
        real(result, path)
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(report, "plot_residuals", full)
    out = tmp_path / "o"
    status = _main([str(_csv(tmp_path)), "--fit", "E", "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert status == 2 and "No space left on device" in err and "--out" in err, err
    assert "Traceback" not in err
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".o.")] == []
