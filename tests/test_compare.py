"""`rrr4 compare`: a user's run against the committed result, without run-specific numbers."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from rrr4.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _copy(tmp_path: Path, name: str) -> Path:
    d = tmp_path / name
    d.mkdir()
    shutil.copy(ROOT / "results" / "paper_circle" / "summary.json", d / "summary.json")
    return d


def _edit(d: Path, arm: str, key: str, factor: float) -> None:
    s = json.loads((d / "summary.json").read_text())
    s[arm][key] *= factor
    (d / "summary.json").write_text(json.dumps(s))


def test_run_specific_numbers_are_ignored_and_results_are_not(tmp_path, capsys):
    a, b = _copy(tmp_path, "a"), _copy(tmp_path, "b")
    _edit(b, "with_preload", "wall_time_s", 3.0)
    assert main(["compare", str(a), str(b)]) == 0
    _edit(b, "with_preload", "platform_error_rms_m", 1.05)
    assert main(["compare", str(a), str(b)]) == 1
    out = capsys.readouterr().out
    assert "1 differ" in out and "with_preload.platform_error_rms_m" in out
    assert main(["compare", str(a), str(b), "--rtol", "0.1"]) == 0


def test_bad_directories_in_one_line(tmp_path, capsys):
    assert main(["compare", str(tmp_path), str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no summary.json" in err[0]
    (tmp_path / "summary.json").write_text("{not json")
    assert main(["compare", str(tmp_path), str(tmp_path)]) == 2
    assert "not valid JSON" in capsys.readouterr().err
