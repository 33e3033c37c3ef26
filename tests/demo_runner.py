"""Run a demo script as a user does and read its JSON summary."""

import json
import os
import subprocess
import sys
from pathlib import Path

DEMOS = Path(__file__).resolve().parents[1] / "demos"


def run_demo(name: str, *args: str, cwd, env: dict | None = None, fails: bool = False) -> str:
    """Standard output of ``python demos/<name> <args>``; fails the test unless it exits 0.

    ``env`` adds to the environment the demo inherits. With ``fails`` the demo must
    instead end on its own failed check against its reference: exit status 1, a
    ``check: ... FAIL`` line, and no traceback.
    """
    # As in the suite (pyproject.toml), a RuntimeWarning (overflow, 0/0) fails the demo.
    # The demos compile at -O1, the in-process tests at -O0 (conftest.py).
    env = {**os.environ, "XDG_CONFIG_HOME": os.environ["FE_MPM_DEMO_JIT_CONFIG"], **(env or {})}
    out = subprocess.run(
        [sys.executable, "-W", "error::RuntimeWarning", str(DEMOS / name), *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    if fails:
        assert out.returncode == 1 and "Traceback" not in out.stderr, out.stderr[-3000:]
        assert check_line(out.stdout).endswith(": FAIL"), out.stdout[-3000:]
    else:
        assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def check_line(stdout: str) -> str:
    """The line in which a demo compares its result with its reference (``check: ...``)."""
    lines = [line for line in stdout.splitlines() if line.startswith("check: ")]
    assert len(lines) == 1, stdout[-3000:]
    return lines[0]


def last_json(stdout: str) -> dict:
    """The JSON object a demo prints on its last line with ``--json``."""
    return json.loads(stdout.strip().splitlines()[-1])
