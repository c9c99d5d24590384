"""The README's and the user guide's examples are tests.

Every fenced ``sh`` or ``python`` block of README.md and of every page under docs/ (the result
files under docs/results/ aside) runs, page by page, in the order of the page, in one fresh
temporary working directory per page that holds only links to the repository's ``examples/`` and
``docs/`` folders (as a user in the root of a clone has them). A block that is not to be run says why in the
line before it: ``<!-- not-run: REASON -->`` (an installation step, the long form of a runnable
short form given beside it, a cluster address, a Rust build). Shell blocks run under
``bash -e -o pipefail``; ``pip install ...`` lines are skipped (the package under test is already
installed). A block fails the test when it exits non-zero.

The blocks of one page build on each other (``beamslider plot`` re-plots what ``beamslider
simulate`` wrote), so a page is one test; pytest-xdist runs pages in parallel.
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
PAGES = [ROOT / "README.md", *sorted(p for p in (ROOT / "docs").rglob("*.md")
                                     if p.relative_to(ROOT / "docs").parts[0] not in ("results", "_build"))]
NOT_RUN = re.compile(r"^<!-- not-run: (\S.*\S) -->$")
RUNNABLE = "<!-- runnable -->"  # the default; kept as an explicit marker where a page wants one
TIMEOUT_S = 900

SHELL_PRELUDE = """\
pip() { echo "(documentation test: skipped: pip $*)"; }
"""


def code_blocks(path: Path) -> List[Tuple[int, str, str, str]]:
    """(line number, language, code, reason not to run or "") of each ``sh``/``python`` block."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks = []
    i = 0
    while i < len(lines):
        m = re.match(r"^```(\w*)\s*$", lines[i].strip()) if lines[i].startswith("```") else None
        if m is None:
            i += 1
            continue
        k = i + 1
        while k < len(lines) and lines[k].strip() != "```":
            k += 1
        lang = m.group(1)
        if lang in ("sh", "bash", "python"):
            before = lines[i - 1].strip() if i > 0 else ""
            skip = NOT_RUN.match(before)
            if before.startswith("<!--") and not skip and before != RUNNABLE:
                raise ValueError(f"{path.name}:{i}: unknown marker {before!r} (use {RUNNABLE} or <!-- not-run: REASON -->)")
            blocks.append((i + 2, "python" if lang == "python" else "sh", "\n".join(lines[i + 1:k]) + "\n",
                           skip.group(1) if skip else ""))
        i = k + 1
    return blocks


def test_pages_have_runnable_examples():
    for page in PAGES:
        assert page.exists(), page
    readme = code_blocks(ROOT / "README.md")
    langs = [b[1] for b in readme if not b[3]]
    assert langs.count("sh") >= 2 and langs.count("python") >= 1, readme
    for page in PAGES:
        for line, lang, code, reason in code_blocks(page):
            assert reason or code.strip(), f"{page.name}:{line}: empty block"


@pytest.fixture
def workdir(tmp_path):
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    (tmp_path / "docs").symlink_to(ROOT / "docs", target_is_directory=True)
    return tmp_path


def run_block(lang: str, code: str, cwd: Path, name: str) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env["MPLBACKEND"] = "Agg"
    if lang == "python":
        script = cwd / f"{name}.py"
        script.write_text(code, encoding="utf-8")
        cmd = [sys.executable, script.name]
    else:
        script = cwd / f"{name}.sh"
        script.write_text(SHELL_PRELUDE + code, encoding="utf-8")
        cmd = ["bash", "-e", "-o", "pipefail", script.name]
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)


@pytest.mark.docs
@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_page_examples_in_order(page, workdir):
    """All blocks of one page in one test, in the page's order, in one folder."""
    for line, lang, code, reason in code_blocks(page):
        if reason:
            continue
        t0 = time.perf_counter()
        r = run_block(lang, code, workdir, f"{page.stem}_line{line}")
        wall = time.perf_counter() - t0
        assert r.returncode == 0, (
            f"{page.relative_to(ROOT)}:{line}: the {lang} example failed (exit {r.returncode}, {wall:.1f} s)\n"
            f"--- code ---\n{code}--- stdout ---\n{r.stdout[-3000:]}--- stderr ---\n{r.stderr[-3000:]}"
        )
