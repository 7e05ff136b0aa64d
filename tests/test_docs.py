"""The documentation builds without broken links, and its examples run and print what it says."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from circuitnsds.cli.main import main

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```\s*$", re.MULTILINE | re.DOTALL)
TESTED_PAGES = ["getting-started.md", "api.md", "pss.md", "ac.md"]
"""Pages whose code blocks are complete programs (other pages show signatures and fragments)."""


def test_mkdocs_builds_strict(tmp_path):
    try:
        import mkdocs  # noqa: F401
    except ImportError:
        pytest.fail("mkdocs is not installed: python -m pip install -e \".[test]\"", pytrace=False)
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict",  # (--quiet would hide the warnings)
         "-f", str(ROOT / "mkdocs.yml"), "-d", str(tmp_path / "site")],
        capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    assert (tmp_path / "site" / "theory" / "index.html").exists()


def test_every_page_is_in_the_navigation():
    nav = (ROOT / "mkdocs.yml").read_text()
    for page in DOCS.glob("*.md"):
        assert f": {page.name}" in nav, f"{page.name} is not in mkdocs.yml's nav"


def test_readme_links_exist():
    readme = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", readme)
    local = [link for link in links if "://" not in link]
    assert local, "the README links to the documentation"
    for link in local:
        assert (ROOT / link).exists(), f"README links to missing {link}"


def blocks(page: str) -> list[tuple[str, str, str]]:
    """``(language, code, expected output)`` of each fenced block; the output is the text of a
    bare fence that follows a ``sh`` block directly."""
    text = (DOCS / page).read_text()
    matches = list(FENCE.finditer(text))
    found = []
    for k, match in enumerate(matches):
        expected = ""
        following = matches[k + 1] if k + 1 < len(matches) else None
        if (match.group(1) == "sh" and following is not None and following.group(1) == ""
                and not text[match.end():following.start()].strip()):
            expected = following.group(2)
        found.append((match.group(1), match.group(2), expected))
    return found


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """An empty folder with the bundled netlists, as seen from the repository root."""
    (tmp_path / "netlists").symlink_to(ROOT / "netlists", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("page", TESTED_PAGES)
def test_python_blocks_run(page, workdir):
    codes = [code for language, code, _ in blocks(page) if language == "python"]
    assert codes
    for code in codes:
        exec(compile(code, f"{page} block", "exec"), {"__name__": "__docs__"})


def test_shell_commands_of_getting_started_run_and_print_what_the_page_shows(workdir, capsys):
    ran = 0
    for language, code, expected in blocks("getting-started.md"):
        if language != "sh":
            continue
        for line in code.splitlines():
            if not line.startswith("circuitnsds "):
                continue  # pip install: not run here
            capsys.readouterr()
            assert main(shlex.split(line)[1:]) == 0, line
            ran += 1
            if expected:
                assert capsys.readouterr().out.strip() == expected.strip()
    assert ran >= 4
    assert (workdir / "bridge.png").exists() and (workdir / "bridge.raw").exists()
