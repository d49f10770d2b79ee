"""The package's version and the source tree's git commit: what the firmware reports and a run records."""
from __future__ import annotations

import subprocess
from pathlib import Path

__all__ = ["git_commit", "package_version"]

ROOT = Path(__file__).resolve().parents[1]


def package_version() -> str:
    """The installed package's version ("unknown" when it is not installed)."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("wavekeep")
    except PackageNotFoundError:
        return "unknown"


def git_commit(length: int = 12, dirty: bool = True) -> str | None:
    """The source tree's commit, ``length`` hex digits (``+dirty`` with uncommitted changes when ``dirty``),
    or None outside a git checkout."""
    try:
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", f"--short={length}", "HEAD"],
                              capture_output=True, text=True, timeout=5)
        if head.returncode != 0:
            return None
        changed = dirty and subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                                           capture_output=True, text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip()[:length] + ("+dirty" if changed else "")
