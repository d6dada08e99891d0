"""The README's Python quick start runs as shown (issue 25: every command the README shows
is executed by a test; its shell blocks are run by crates/photostereo-cli/tests/doc_examples.rs)."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]


def test_readme_python_quick_start_runs(cli, tmp_path, monkeypatch):
    text = (REPO / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "the README has no ```python block"
    # the folder it reads, as the README's command-line quick start renders it
    cli("synth", "--shape", "vase", "--material", "plastic", "--size", "128",
        "--calib-sphere", "60", "-o", tmp_path / "my" / "vase")
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, str(REPO / "README.md"), "exec"), {})
    assert (tmp_path / "my" / "vase.lut").is_file()
    assert (tmp_path / "my" / "py_run" / "run.json").is_file()
