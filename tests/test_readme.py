"""Every command and code block in README.md and docs/*.md runs as written.

The README is what a new user tries first, and docs/ where they go next, so each
of their blocks is executed here, in a fresh process, from a folder laid out like
the repository (``scenes/`` and ``scenes_xml/``, default and portable XML) whose
scenes are the project's examples shrunk to a few pixels, so that it all runs in
seconds (README first, then docs/ by name):

* ``sh`` blocks: every line is run by bash as written, the shell a newcomer types them
  into (``source .venv/bin/activate``), from a clone whose ``.venv`` is the suite's own
  (``make`` lines are the suite's own entry point and are checked with ``make -n`` instead);
* ``python`` blocks: run by the project's interpreter;
* ``json`` blocks: the documented ``--stats`` file has exactly the keys a real
  ``--stats`` file has;
* untagged blocks: scene files, which must parse;
* ``text`` blocks: listings (signatures, a command's synopsis, JSON with comments),
  shown and not run; no other kind of block is allowed.

The README's first screen, up to its first link into docs/, is at most
:data:`FIRST_SCREEN` lines: what whitted is, a picture, the two commands, a few
command lines and a Python block.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from whitted.cli import main
from whitted.converter import parse_text

from conftest import without_headline_rounds

REPO = Path(__file__).resolve().parent.parent
README = REPO / "README.md"
#: Every file whose blocks must run: the README, then docs/ by name.
DOCUMENTS = [README, *sorted((REPO / "docs").glob("*.md"))]
SMALL = "size 24 16"
#: The most lines the README may take before its first link into docs/.
FIRST_SCREEN = 80
KINDS = ("sh", "python", "json", "", "text")


def all_blocks() -> list[tuple[str, str, str]]:
    """Every fenced code block of :data:`DOCUMENTS` as (file name, language, text)."""
    found = []
    for document in DOCUMENTS:
        text = document.read_text(encoding="utf-8")
        found += [(document.relative_to(REPO).as_posix(), m.group(1), m.group(2))
                  for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, re.S | re.M)]
    return found


def blocks(kind: str) -> list[str]:
    """The fenced code blocks of language ``kind`` ('' for untagged ones), README first."""
    return [text for _, language, text in all_blocks() if language == kind]


def shell_lines() -> list[str]:
    lines = []
    for block in blocks("sh"):
        for line in block.splitlines():
            command = re.sub(r"\s+#.*$", "", line).strip()
            if command and not command.startswith("#") and command not in lines:
                lines.append(command)
    return lines


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A folder like a fresh clone of the repository (no out/), its example scenes shrunk to
    24x16 pixels. The shell lines run in it one after the other, as a user types them."""
    root = tmp_path_factory.mktemp("readme")
    shutil.copytree(REPO / "scenes", root / "scenes",
                    ignore=shutil.ignore_patterns("*.xml", "__pycache__"))
    for scene in (root / "scenes").glob("*.scn"):
        text = re.sub(r"(?im)^\s*size\s+\d+\s+\d+\s*$", SMALL, scene.read_text())
        if SMALL not in text:
            text = SMALL + "\n" + text
        scene.write_text(text)
    (root / "scenes_xml").mkdir()
    for portable in ([], ["--portable"]):
        assert main(["convert", str(root / "scenes"), "-o", str(root / "scenes_xml"),
                     *portable]) == 0
    # No out/: the README's blocks must run from a fresh clone, before `make demo` makes it.
    # A checkout of its own, ignoring what the repository ignores: the README's commands
    # must leave `git status` clean (their outputs under out/ or ignored).
    shutil.copy(REPO / ".gitignore", root / ".gitignore")
    for command in (["init", "-q"], ["add", "-A"],
                    ["-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "clone"]):
        subprocess.run(["git", *command], cwd=root, check=True)
    # `make demo`'s .venv, as a link to the one running the suite (ignored as the folder is)
    (root / ".venv").symlink_to(Path(sys.executable).parent.parent, target_is_directory=True)
    with open(root / ".git" / "info" / "exclude", "a") as exclude:
        exclude.write(".venv\n")
    return root


def untracked(root: Path) -> str:
    """What ``git status`` would show a user after running something in ``root``."""
    return subprocess.run(["git", "status", "--porcelain"], cwd=root, capture_output=True, text=True,
                          check=True).stdout


def environment() -> dict:
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    return env


def test_the_documents_have_blocks_of_every_kind_and_no_other():
    assert shell_lines() and blocks("python") and blocks("json") and blocks("")
    assert {(name, language) for name, language, _ in all_blocks() if language not in KINDS} == set()


def test_the_readme_s_first_screen_starts_a_newcomer():
    """Up to its first link into docs/ (a link, not the picture), the README says what
    whitted is, shows a render, gives the two commands, command lines and Python."""
    lines = README.read_text(encoding="utf-8").splitlines()
    first = next(i for i, line in enumerate(lines) if re.search(r"(?<!!)\[[^\]]*\]\(docs/", line))
    screen = "\n".join(lines[:first])
    assert first <= FIRST_SCREEN, f"the first link into docs/ is on line {first + 1}"
    picture = re.search(r"!\[[^\]]*\]\((docs/images/[^)]+\.png)\)", screen)
    assert picture and (REPO / picture.group(1)).is_file()
    assert "make demo" in screen and "make test" in screen
    commands = [line for line in screen.splitlines() if line.startswith("whitted ")]
    assert len(commands) >= 5 and "```python" in screen


@pytest.mark.parametrize("command", [c for c in shell_lines() if c.startswith("make ")])
def test_make_targets_exist(command):
    run = subprocess.run(["make", "-n", *command.split()[1:]], cwd=REPO, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr


def in_process(command: str) -> list[str] | None:
    """The arguments of a plain ``whitted`` line (no shell syntax beyond words), which runs
    through :func:`whitted.cli.main` in the suite's own process, as the ``whitted`` script
    would run it; None for any other line, which bash runs (the lines that start the script
    itself, ``.venv/bin/whitted`` and ``source .venv/bin/activate``, among them)."""
    words = shlex.split(command)
    if words[0] != "whitted" or set(command) & set("<>|;&$`*?~\\'\""):
        return None
    return words[1:]


def run_in_process(arguments: list[str], workdir: Path, monkeypatch, capsys) -> tuple[int, str]:
    """(exit status, stderr) of ``whitted ARGUMENTS`` run by :func:`whitted.cli.main` in
    ``workdir``; a comparison without its headlines' extra rounds (no test reads them here)."""
    from whitted.cli import main
    without_headline_rounds(monkeypatch)
    monkeypatch.chdir(workdir)
    monkeypatch.setenv("PATH", environment()["PATH"])
    try:
        status = main(arguments)
    except SystemExit as exit:
        status = exit.code
    return status, capsys.readouterr().err


@pytest.mark.parametrize("command", [c for c in shell_lines() if not c.startswith("make ")])
def test_shell_command_runs_as_written(command, workdir, monkeypatch, capsys):
    arguments = in_process(command)
    if arguments is None:
        run = subprocess.run(command, shell=True, executable=shutil.which("bash"), cwd=workdir,
                             env=environment(), capture_output=True, text=True, timeout=600)
        status, stderr = run.returncode, run.stderr
    else:
        status, stderr = run_in_process(arguments, workdir, monkeypatch, capsys)
    assert status == 0, f"{command}\n{stderr}"
    assert "Traceback" not in stderr
    assert untracked(workdir) == "", command


@pytest.fixture
def fresh_clone(workdir, tmp_path):
    """A copy of the clone as it was made: without out/ or anything else the shell lines
    wrote (each Python block must run on its own, before `make demo`)."""
    clone = tmp_path / "clone"
    shutil.copytree(workdir, clone, symlinks=True, ignore=shutil.ignore_patterns("out"))
    subprocess.run(["git", "clean", "-qfdx"], cwd=clone, check=True)
    assert not (clone / "out").exists()
    return clone


@pytest.mark.parametrize("index", range(len(blocks("python"))))
def test_python_block_runs_as_written(index, fresh_clone):
    code = blocks("python")[index]
    run = subprocess.run([sys.executable, "-c", code], cwd=fresh_clone, env=environment(),
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, f"{code}\n{run.stderr}"
    assert untracked(fresh_clone) == "", code


def test_documented_stats_have_the_real_keys(workdir, monkeypatch, capsys):
    documented = next(block for block in map(json.loads, blocks("json")) if "rays" in block)
    out = workdir / "out" / "readme-stats.json"
    out.parent.mkdir(exist_ok=True)
    arguments = ["render", "scenes/tir.scn", "-o", "out/readme-stats.png", "--stats", str(out),
                 "-q"]
    assert run_in_process(arguments, workdir, monkeypatch, capsys)[0] == 0
    real = json.loads(out.read_text())
    assert sorted(documented) == sorted(real)
    assert sorted(documented["rays"]) == sorted(real["rays"])


@pytest.mark.parametrize("index", range(len(blocks(""))))
def test_scene_blocks_parse(index):
    scene = parse_text(blocks("")[index], "a scene block")
    assert scene.spheres or scene.lights
