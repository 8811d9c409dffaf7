#!/usr/bin/env python3
"""One-command setup on a fresh machine (Python ≥ 3.11 and nothing else), then run a job.

    python3 bootstrap.py run     # create .venv if needed, install fleetnav, run the main job (a mission)
    python3 bootstrap.py test    # create .venv if needed, install fleetnav[dev], run the test suite
    python3 bootstrap.py lint    # ruff + mypy

Idempotent: the venv is reused, and packages are reinstalled only when pyproject.toml changes.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import venv
from pathlib import Path

ROOT = Path(__file__).resolve().parent
VENV = ROOT / ".venv"
BIN = VENV / ("Scripts" if os.name == "nt" else "bin")
PY = BIN / ("python.exe" if os.name == "nt" else "python")
STAMP = VENV / ".fleetnav-installed"


def ensure_env() -> None:
    if sys.version_info < (3, 11):  # noqa: UP036 - this file must also run (and fail clearly) on older Pythons
        sys.exit(f"fleetnav needs Python ≥ 3.11; this is {sys.version.split()[0]}")
    if not PY.exists():
        print(f"creating {VENV} ...", flush=True)
        venv.EnvBuilder(with_pip=True).create(VENV)
    want = hashlib.sha256((ROOT / "pyproject.toml").read_bytes()).hexdigest()
    if STAMP.exists() and STAMP.read_text().strip() == want:
        return
    print("installing fleetnav and its dependencies (once; ~1 min) ...", flush=True)
    pip = [str(PY), "-m", "pip", "install", "--disable-pip-version-check", "-q"]
    subprocess.run([*pip, "--upgrade", "pip"], check=True)
    subprocess.run([*pip, "-e", f"{ROOT}[dev]"], check=True)
    STAMP.write_text(want)


def main(argv: list[str]) -> int:
    job = argv[0] if argv else "run"
    rest = argv[1:]
    ensure_env()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    if job == "run":
        cmd = [str(BIN / "fleetnav"), "run", *(rest or ["configs/missions/arena_navigation.yaml"])]
    elif job == "test":
        cmd = [str(PY), "-m", "pytest", *rest]
    elif job == "lint":
        rc = subprocess.run([str(PY), "-m", "ruff", "check", "."], cwd=ROOT, env=env).returncode
        return rc or subprocess.run([str(PY), "-m", "mypy", "."], cwd=ROOT, env=env).returncode
    else:
        print(f"unknown job '{job}': use run, test or lint", file=sys.stderr)
        return 2
    return subprocess.run(cmd, cwd=ROOT, env=env).returncode


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
