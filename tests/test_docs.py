"""Every path the code and the docs cite exists: a newcomer follows them first.

Scans each tracked (or new, not ignored) ``.py`` and ``.md`` file for paths under ``docs/``, ``runtime/``,
``trainer/``, ``export/``, ``tests/`` and ``models/`` that end in a file suffix, and for decision pages cited by
their name alone (``NNN-name.md``), and fails listing those that are not in the tree. A path that is gone may be
named only inside ``CHANGELOG.md`` as ``git show <commit>:PATH`` (where it is read from git history); elsewhere,
write ``git show <commit>:./PATH`` (git's form relative to the repository root), which is not taken for a path in
the tree. The rule is that of the landing check
(``../shared/hooks/before-stop``).
"""

import re
import subprocess
from pathlib import Path
from typing import Iterable, List, Tuple

REPO = Path(__file__).resolve().parents[1]

#: Top-level folders whose paths are checked.
ROOTS = ("docs", "runtime", "trainer", "export", "tests", "models")
#: File suffixes that make a string a file path (the landing check's).
SUFFIXES = ("md", "py", "json", "png", "jpg", "sh", "html", "csv")
#: A path: one of :data:`ROOTS`, not preceded by a word character, ``/`` or ``.`` (so ``../docs/x.md`` and
#: ``git show abc1234:./docs/x.md`` are not taken), ending in a word character and one of :data:`SUFFIXES`.
PATH = re.compile(r"(?<![\w/.])((?:%s)/[\w./-]*\w\.(?:%s))" % ("|".join(ROOTS), "|".join(SUFFIXES)))
#: A decision page cited by its file name alone (``(006-highlight-fill.md)``): it lives in docs/decisions/.
DECISION = re.compile(r"(?<![\w/.-])([0-9]{3}-[\w-]+\.md)")
#: ``git show <commit>:PATH``: the form in which CHANGELOG.md may name a path that left the tree.
GIT_SHOW = re.compile(r"git show [0-9a-f]{7,40}:\S+")


def tracked_files(root: Path = REPO) -> List[Path]:
    """The ``.py`` and ``.md`` files of the checkout: tracked, or new and not ignored (a plain walk without git)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=root,
                             capture_output=True, check=True).stdout.decode()
        names = [n for n in out.split("\0") if n]
    except (OSError, subprocess.CalledProcessError):
        skip = {".git", ".venv", "node_modules"}
        names = [str(p.relative_to(root)) for p in root.rglob("*") if not skip & set(p.relative_to(root).parts)]
    return sorted(root / n for n in names if n.endswith((".py", ".md")) and (root / n).is_file())


def dead_paths(root: Path, files: Iterable[Path]) -> List[Tuple[str, int, str]]:
    """``(file, line, path)`` of each cited path that does not exist under ``root`` (``git show`` texts excepted in
    CHANGELOG.md)."""
    dead = []
    for f in files:
        text = f.read_text(encoding="utf-8", errors="ignore")
        for number, line in enumerate(text.splitlines(), 1):
            if f.name == "CHANGELOG.md":
                line = GIT_SHOW.sub("", line)
            paths = PATH.findall(line) + ["docs/decisions/" + name for name in DECISION.findall(line)]
            for path in paths:
                if not (root / path).exists():
                    dead.append((str(f.relative_to(root)), number, path))
    return dead


def test_every_cited_path_exists():
    dead = dead_paths(REPO, tracked_files())
    assert not dead, "paths cited that do not exist:\n" + "\n".join(f"{f}:{n}: {p}" for f, n, p in dead)


def _spelt(text: str) -> str:
    """``text`` with the placeholders ``DOCS``, ``TESTS``, ``TRAINER`` spelt as the folders (so that this file
    itself cites no dead path)."""
    return text.replace("DOCS", "docs").replace("TESTS", "tests").replace("TRAINER", "trainer")


def _write(path: Path, text: str) -> Path:
    path.write_text(_spelt(text))
    return path


def test_a_dead_path_is_found_and_git_history_is_not(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "here.md").write_text("x")
    notes = _write(tmp_path / "notes.md",
                   "See DOCS/here.md and DOCS/gone/README.md;\n`git show abc1234:./DOCS/gone/old.py` is history.\n"
                   "Not a path: ../DOCS/up.md, myDOCS/x.md.\n`git show abc1234:DOCS/gone/b.md` outside CHANGELOG.\n")
    changelog = _write(tmp_path / "CHANGELOG.md",
                       "Read with `git show abc1234:DOCS/benchmarks/x/README.md`; TESTS/missing_test.py\n")
    code = _write(tmp_path / "mod.py", '"""Study: bc3896e:TRAINER/bench/speed.py."""\n# chosen: (9' '99-gone.md)\n')
    assert dead_paths(tmp_path, [notes, changelog, code]) == [
        ("notes.md", 1, _spelt("DOCS/gone/README.md")), ("notes.md", 4, _spelt("DOCS/gone/b.md")),
        ("CHANGELOG.md", 1, _spelt("TESTS/missing_test.py")), ("mod.py", 1, _spelt("TRAINER/bench/speed.py")),
        ("mod.py", 2, _spelt("DOCS/decisions/9" "99-gone.md"))]


def test_the_decision_pages_are_indexed():
    """Each page of docs/decisions/ has its line in the index, and each line of the index names a page."""
    folder = REPO / "docs" / "decisions"
    pages = sorted(p.name for p in folder.glob("[0-9][0-9][0-9]-*.md"))
    index = (folder / "README.md").read_text(encoding="utf-8")
    listed = sorted(set(re.findall(r"\(([0-9]{3}-[\w-]+\.md)\)", index)))
    assert pages and listed == pages


def test_the_architecture_names_every_module():
    """docs/architecture.md gives each module of runtime/, trainer/ and export/ its line (the Blender add-on's
    package is named as one)."""
    text = (REPO / "docs" / "architecture.md").read_text(encoding="utf-8")
    modules = [f for f in tracked_files() if f.suffix == ".py" and f.relative_to(REPO).parts[0] in
               ("runtime", "trainer", "export") and f.name != "__init__.py" and "blender_addon" not in f.parts]
    missing = [str(f.relative_to(REPO)) for f in modules if f.name not in text]
    assert modules and not missing, "modules docs/architecture.md does not name: " + ", ".join(missing)
