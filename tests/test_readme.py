"""The README's examples are tests: every fenced ``sh`` or ``python`` block preceded by the line
``<!-- runnable -->`` is run, in the order of the README, in one fresh temporary working directory
that holds only a link to the repository's ``examples/`` folder (as a user in the root of a clone
has it). Shell blocks run under ``bash -e -o pipefail``; ``pip install ...`` lines are skipped
(the package under test is already installed). A block fails the test when it exits non-zero.

Blocks build on each other (``beamslider plot`` re-plots what ``beamslider simulate`` wrote), so
they run as one test, which a pytest-xdist worker cannot split.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import List, Tuple

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
MARK = "<!-- runnable -->"
TIMEOUT_S = 900

SHELL_PRELUDE = """\
pip() { echo "(README test: skipped: pip $*)"; }
"""


def runnable_blocks(text: str) -> List[Tuple[int, str, str]]:
    """(line number, language, code) of each marked block."""
    lines = text.splitlines()
    blocks = []
    i = 0
    while i < len(lines):
        if lines[i].strip() == MARK:
            j = i + 1
            m = re.match(r"^```(\w+)\s*$", lines[j].strip()) if j < len(lines) else None
            if m is None or m.group(1) not in ("sh", "python"):
                raise ValueError(f"README.md:{i + 1}: {MARK} must be followed by a ```sh or ```python fence")
            k = j + 1
            while k < len(lines) and lines[k].strip() != "```":
                k += 1
            blocks.append((j + 1, m.group(1), "\n".join(lines[j + 1:k]) + "\n"))
            i = k
        i += 1
    return blocks


BLOCKS = runnable_blocks(README.read_text(encoding="utf-8"))


@pytest.fixture
def workdir(tmp_path):
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    return tmp_path


def test_readme_has_runnable_examples():
    langs = [b[1] for b in BLOCKS]
    assert langs.count("sh") >= 2 and langs.count("python") >= 1, BLOCKS


def run_block(lang: str, code: str, cwd: Path, line: int) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env["MPLBACKEND"] = "Agg"
    if lang == "python":
        script = cwd / f"readme_line{line}.py"
        script.write_text(code, encoding="utf-8")
        cmd = [sys.executable, script.name]
    else:
        script = cwd / f"readme_line{line}.sh"
        script.write_text(SHELL_PRELUDE + code, encoding="utf-8")
        cmd = ["bash", "-e", "-o", "pipefail", script.name]
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)


def test_readme_examples_in_order(workdir):
    """All blocks in one test, in the README's order, in one folder: they build on each other, and
    one test cannot be split between pytest-xdist workers (scripts/test.sh runs two)."""
    for line, lang, code in BLOCKS:
        t0 = time.perf_counter()
        r = run_block(lang, code, workdir, line)
        wall = time.perf_counter() - t0
        assert r.returncode == 0, (
            f"README.md:{line}: the {lang} example failed (exit {r.returncode}, {wall:.1f} s)\n"
            f"--- code ---\n{code}--- stdout ---\n{r.stdout[-3000:]}--- stderr ---\n{r.stderr[-3000:]}"
        )
