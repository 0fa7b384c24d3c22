"""Shared fixtures."""
from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
#: the project's shared folder beside the checkout (CI puts it there): real programs and
#: recordings whose licences forbid copies in the repository, so tests read them in place
SHARED = REPO.parent / "shared"


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO


@pytest.fixture(scope="session")
def shared() -> Path:
    """``REPO.parent / "shared"``; its absence fails the test (never skips it)."""
    if not (SHARED / "data" / "real").is_dir():
        pytest.fail(f"the shared data folder {SHARED} is missing: tests read the real programs and "
                    f"recordings in place from 'shared' beside the checkout (CI clones the "
                    f"repository next to it); link or copy it there", pytrace=False)
    return SHARED


@pytest.fixture(scope="session")
def mikron():
    from ncsim.machine import load_machine

    return load_machine("mikron")


@pytest.fixture(autouse=True)
def fresh_kernel_choice():
    """Each test starts as a fresh ``ncsim`` process does: no compiled kernel has run yet, so
    small inputs run as plain Python (``ncsim.jit``). Without this, a test after one that ran
    a compiled kernel would compile (and, on a cold numba cache, print the compile notice)
    where the real command would not."""
    from ncsim import jit

    jit._active = False
    yield


@pytest.fixture(autouse=True)
def no_compile_notice_in_outputs(monkeypatch):
    """The CLI's "compiling kernels" line depends on the state of numba's cache (a fresh clone
    compiles wherever a kernel is first used), not on the command: tests that compare stderr
    run without it. ``tests/test_jit.py`` tests the notice itself, in fresh processes with an
    empty cache of their own."""
    import ncsim.cli.main

    monkeypatch.setattr(ncsim.cli.main, "_compile_notice", lambda text: None)
    yield
