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
    assert namespace["r"].index == 8 and namespace["run"]["frames"]["x_m"].shape == (9,)
