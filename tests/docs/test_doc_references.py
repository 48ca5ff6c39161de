"""What the README and docs/ name exists: linked pages and figures, files of the repository, contin's names.

A page that names ``tests/hb/test_crossings.py``, ``scripts/bench/bench_rotor.py`` or
``contin.hb.harmonics.index`` sends the reader there; when a file moves or a name is
renamed, this test says which page still points at the old place.
"""

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+)\)")
FILE = re.compile(r"(?<![\w./-])((?:scenes|scripts|tests|docs|models)/[\w./-]*\.(?:py|yaml|md|png))(?:::(\w+))?")
NAME = re.compile(r"`(contin(?:\.\w+)+)")


def _name(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


def resolve(dotted: str):
    """The module or attribute ``dotted`` names (ImportError / AttributeError when it names nothing)."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(dotted)


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_links_point_at_pages_and_figures_that_exist(page):
    text = page.read_text(encoding="utf-8")
    missing = []
    for target in LINK.findall(text):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue
        path = (page.parent / target.split("#", 1)[0]).resolve()
        if not path.exists():
            missing.append(target)
    assert not missing, f"{_name(page)} links to missing files: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_files_named_exist(page):
    text = page.read_text(encoding="utf-8")
    missing = []
    for path, test in FILE.findall(text):
        if not (ROOT / path).exists():
            missing.append(path)
        elif test and f"def {test}(" not in (ROOT / path).read_text(encoding="utf-8"):
            missing.append(f"{path}::{test}")
    assert not missing, f"{_name(page)} names files that do not exist: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_contin_names_exist(page):
    text = page.read_text(encoding="utf-8")
    missing = []
    for dotted in sorted(set(NAME.findall(text))):
        try:
            resolve(dotted)
        except (ImportError, AttributeError):
            missing.append(dotted)
    assert not missing, f"{_name(page)} names what contin does not have: {missing}"
