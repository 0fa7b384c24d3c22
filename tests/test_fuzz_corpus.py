"""The fuzz corpus (``tests/fuzz_corpus.py``, files in ``tests/fuzz/``): every defect the fuzzing
found, run through the CLI as a user would, gives its one clear line (or the right numbers),
its exit status, and never a traceback or a Python warning."""
from __future__ import annotations

import os
import re

import pytest
from click.testing import CliRunner

from fuzz_corpus import CASES, CORPUS, FILES, write
from ncsim.cli.main import cli


def test_the_committed_corpus_is_what_the_generator_writes(tmp_path):
    write(tmp_path)
    assert sorted(p.name for p in CORPUS.iterdir()) == sorted(FILES)
    for name in FILES:
        assert (CORPUS / name).read_bytes() == (tmp_path / name).read_bytes(), (
            f"tests/fuzz/{name} is stale: run python tests/fuzz_corpus.py")


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_case(case, monkeypatch):
    if not all(os.path.exists(p) for p in case.needs):
        pytest.skip(f"needs {', '.join(case.needs)}")
    monkeypatch.chdir(CORPUS)
    r = CliRunner().invoke(cli, list(case.argv))
    assert "Traceback" not in r.output and "Warning:" not in r.stderr, r.output
    assert r.exit_code == case.exit, r.output
    lines = r.stderr.splitlines()
    assert len(lines) == len(case.stderr), lines
    for line, pattern in zip(lines, case.stderr):
        assert re.fullmatch(pattern, line), (line, pattern)
    if case.stdout is not None:
        assert re.search(case.stdout, r.stdout), r.stdout
    if case.exit == 2:
        assert r.stdout == ""
    assert not (CORPUS / "never.png").exists()
