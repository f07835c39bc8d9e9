"""The example of docs/python.md runs as written: its sh block (aerovo simulate) in a scratch
folder, then its python blocks in order, with `run` = the folder of a real `aerovo run`."""
import os
import re
import shlex
import subprocess

import pytest


def blocks(text, lang):
    return re.findall(r"^```" + lang + r"\n(.*?)^```$", text, re.S | re.M)


def test_docs_python_md_runs(cli, run_dir, tmp_path, monkeypatch, capsys):
    source = os.environ.get("AEROVO_SOURCE_DIR")
    if not source:
        pytest.skip("AEROVO_SOURCE_DIR (the source tree) is not set: run through ctest")
    with open(os.path.join(source, "docs", "python.md")) as f:
        text = f.read()
    (sh,) = blocks(text, "sh")
    args = shlex.split(sh.replace("\\\n", " "))
    assert args[0] == "aerovo"
    monkeypatch.chdir(tmp_path)
    cli(*args[1:])
    os.symlink(run_dir, tmp_path / "run")
    code = blocks(text, "python")
    assert len(code) == 2
    namespace = {}
    for block in code:
        exec(compile(block, "docs/python.md", "exec"), namespace)
    out = capsys.readouterr().out
    assert "inliers of" in out and " ok " in out
    assert namespace["r"].index == 4 and namespace["run"]["frames"]["x_m"].shape == (9,)


def test_readme_python_lines_are_in_docs_python_md():
    source = os.environ.get("AEROVO_SOURCE_DIR")
    if not source:
        pytest.skip("AEROVO_SOURCE_DIR (the source tree) is not set: run through ctest")
    with open(os.path.join(source, "docs", "python.md")) as f:
        doc_lines = {line.strip() for line in f}
    with open(os.path.join(source, "README.md")) as f:
        readme = blocks(f.read(), "python")
    lines = [line.strip() for block in readme for line in block.splitlines() if line.strip()]
    assert len(lines) >= 3, "README.md has no Python excerpt"
    for line in lines:
        assert line in doc_lines, f"README line not in docs/python.md: {line}"
