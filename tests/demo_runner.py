"""Run a demo script as a user does and read its JSON summary."""

import json
import os
import subprocess
import sys
from pathlib import Path

DEMOS = Path(__file__).resolve().parents[1] / "demos"


def run_demo(name: str, *args: str, cwd, env: dict | None = None) -> str:
    """Standard output of ``python demos/<name> <args>``; fails the test on a non-zero exit.

    ``env`` adds to the environment the demo inherits.
    """
    # As in the suite (pyproject.toml), a RuntimeWarning (overflow, 0/0) fails the demo.
    # The demos compile at -O1, the in-process tests at -O0 (conftest.py).
    env = {**os.environ, "XDG_CONFIG_HOME": os.environ["FE_MPM_DEMO_JIT_CONFIG"], **(env or {})}
    out = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", str(DEMOS / name),
                          *args], cwd=cwd, env=env,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def last_json(stdout: str) -> dict:
    """The JSON object a demo prints on its last line with ``--json``."""
    return json.loads(stdout.strip().splitlines()[-1])
